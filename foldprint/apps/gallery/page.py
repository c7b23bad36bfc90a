"""The gallery's one HTML page (``index.html``): the summary table, the materials chart
and a section per design (inline CSS, no scripts, relative links)."""

from __future__ import annotations

import textwrap

from ...core.version import __version__
from ...core.constants import CHECK_SAMPLES, CHECK_SEED
from ...model import composition
from ...model.materials import MaterialLibrary
from ...checks.report import more_findings
from ...core.display import clip_by, hinge_folds, hinge_text, seconds
from .entry import Entry, Image, Link, esc, fmt_s
from .samples import jam_text, mc_html

HINGE_MODEL_TEXT = {
    "arc": "the printed (arc) hinges: each hinge's radius, thickness and width as exported",
    "point": "the paper's point-hinge reduced-order model (a comparison mode, not the printed part)",
}
"""How the page names the hinge model a design was simulated with."""


_CSS = """
:root { color-scheme: light; }
body { font: 15px/1.45 system-ui, -apple-system, "Segoe UI", Roboto, Helvetica, Arial, sans-serif;
       margin: 0 auto; max-width: 1100px; padding: 0 1.2em 3em; color: #1d1d1f; background: #fff; }
h1 { margin: 0.8em 0 0.2em; } h2 { margin-top: 2.2em; border-bottom: 2px solid #ddd; }
h3 { margin: 1.4em 0 0.4em; font-size: 1.05em; }
table { border-collapse: collapse; margin: 0.4em 0; }
th, td { border: 1px solid #ddd; padding: 0.25em 0.6em; text-align: left; vertical-align: top; }
th { background: #f4f4f4; }
td.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
figure { margin: 0.8em 0; }
figcaption { color: #555; font-size: 0.9em; }
img { max-width: 100%; height: auto; border: 1px solid #eee; }
.status { padding: 0.5em 0.8em; border-radius: 4px; font-weight: 600; }
.ok { background: #e6f4ea; color: #1e6b34; } .fail { background: #fdecea; color: #9b1c1c; }
.warn { background: #fff4e0; color: #8a5300; }
dl.legend { display: grid; grid-template-columns: max-content 1fr; gap: 0.15em 1em; font-size: 0.92em; }
dl.legend dt { font-weight: 600; } dl.legend dd { margin: 0; color: #444; }
blockquote { margin: 0; font-style: italic; }
.sev-error { color: #9b1c1c; font-weight: 600; } .sev-warning { color: #8a5300; font-weight: 600; }
.sev-info { color: #555; }
.swatch { display: inline-block; width: 0.9em; height: 0.9em; border: 1px solid #888;
          vertical-align: -0.1em; margin-right: 0.3em; }
.pics { display: grid; grid-template-columns: repeat(auto-fit, minmax(420px, 1fr)); gap: 0.8em 1.2em;
        align-items: start; }
.pics figure.wide { grid-column: 1 / -1; }
.muted { color: #666; }
code { font-size: 0.92em; }
a.button { display: inline-block; padding: 0.3em 0.9em; border-radius: 4px; background: #2f5d9e; color: #fff;
           text-decoration: none; font-weight: 600; }
"""


def nominal_status(entry: Entry) -> tuple[bool, str]:
    """(completed, one-line status text) of a design."""
    sim = entry.sim
    if sim["completed"]:
        return True, (f"Completes in {fmt_s(entry.fold_time)} at {sim['temperature_c']:g} \u00b0C; "
                      "no collision" + (", every goal met." if sim["goals"] else "."))
    reasons = []
    if entry.contacts:
        a, b, t, method = entry.contacts[0]
        reasons.append(f"collision: panels {a} and {b} touch at {seconds(t)} ({method})")
    stalled = [h["id"] for h, done in zip(sim["hinges"], entry.hinge_done) if not done]
    if stalled:
        reasons.append(f"hinges {', '.join(stalled)} do not reach 98 % within {sim['duration_s']:g} s")
    missed = [g["id"] for g in sim["goals"] if not g["met"]]
    if missed:
        reasons.append(f"goals not met: {', '.join(missed)}")
    return False, "Does not complete \u2014 " + "; ".join(reasons) + "."


NO_FILES = "No print files: "
"""How a design's note begins when its printed part cannot be built (the reason follows)."""


#: The check findings that say printed parts jam under scatter (docs/checks.md).
JAM_CODES = ("FP180", "FP181")


def printed_jam(entry: Entry) -> float | None:
    """``foldprint check``'s jam probability when its verdict is that printed parts jam
    under scatter (:data:`JAM_CODES`), else None."""
    chk = entry.checks
    if chk.get("robust") is None or not any(f["code"] in JAM_CODES for f in chk["findings"]):
        return None
    return float(chk["robust"]["jam_probability"])


def nominal_cell(entry: Entry) -> tuple[str, str]:
    """The summary's nominal-fold cell: (CSS class, text). A nominal fold that completes is
    green only when printed parts do not jam under scatter; amber, saying so, when they do."""
    ok, _ = nominal_status(entry)
    if not ok:
        return "fail", "does not complete"
    jam = printed_jam(entry)
    return ("ok", "completes") if jam is None else ("warn", f"nominal: completes; printed parts: jam {100 * jam:.1f} %")


def paper_label(entry: Entry) -> str:
    """How the page names a structure of the paper: "the paper's Sample 1 (Fig. 2b)", or a
    variant "after the paper's Fig. 5"; "" for a design not from the paper. A name the
    paper gives with its article ("the self-locking structure") drops it after "the paper's"."""
    ref = entry.design.paper
    if ref is None:
        return ""
    if not ref.statements:
        return f"{ref.name}, after the paper's {ref.figure}"
    label = ref.label
    return f"the paper's {label[4:] if label.startswith('the ') else label}"  # not "the paper's the box"


def entry_done(entry: Entry) -> str:
    """The progress line of a finished design: what was made, and what was not."""
    done, failed = ["simulated", "checked", "rendered"], []
    if entry.export_note:  # a verdict on the design (its part cannot be built), not a crash
        reason = textwrap.shorten(entry.export_note.removeprefix(NO_FILES), 100, placeholder=" ...")
        failed.append(f"no print files: the part cannot be built ({reason})")
    else:
        done.append("exported")
    if entry.viewer is None:
        failed.append("no 3D viewer")
    return f"{entry.design.name}: {', '.join(done)}" + "".join(f"; {f}" for f in failed)


def check_verdict(entry: Entry) -> tuple[bool, str]:
    """(passes, one line) of ``foldprint check``'s verdict: its exit status and error codes."""
    chk = entry.checks
    codes = list(dict.fromkeys(f["code"] for f in chk["findings"] if f["severity"] == "error"))
    if chk["ok"]:
        return True, f"foldprint check passes (exit 0; {chk['warnings']} warning(s))."
    return False, f"foldprint check fails (exit 1): {chk['errors']} error(s), {', '.join(codes)}."


def _img_html(img: Image) -> str:
    cls = ' class="wide"' if img.wide else ""
    return (f'<figure{cls}><img src="{esc(img.src)}" width="{img.width}" height="{img.height}" '
            f'alt="{esc(img.alt)}"><figcaption>{esc(img.caption)}</figcaption></figure>')


def _link_html(link: Link) -> str:
    size = "" if link.size is None else f' <span class="muted">({_size(link.size)})</span>'
    return f'<li><a href="{esc(link.href)}">{esc(link.label)}</a>{size}</li>'


def _size(n: int) -> str:
    return f"{n} B" if n < 1024 else f"{n / 1024:.1f} kB" if n < 1024 * 1024 else f"{n / 1024 ** 2:.1f} MB"


def _ramp_note(d) -> str:
    """The VeroWhite ramp's legend under the hinge table, when a hinge names a fraction."""
    ramp = composition.ramp_legend(h.material for h in d.hinges)
    if ramp is None:
        return ""
    bar = (f'<span class="swatch" style="width:6em;background:linear-gradient(to right, {esc(ramp["tangoblack"])}, '
           f'{esc(ramp["verowhite"])})"></span>')
    items = "; ".join(f"{esc(n)}: {esc(t)}" for n, t in ramp["labels"].items())
    return (f'<p class="muted">{bar} VeroWhite fraction, TangoBlack 0 to VeroWhite 1 (usable '
            f'{ramp["range"][0]:.3f}-{ramp["range"][1]:.3f}; docs/composition.md). {items}</p>')


def _swatch(lib: MaterialLibrary, material: str) -> str:
    color = lib[material].color[:7] if material in lib else "#9a9a9a"
    if composition.is_composition_name(material):  # the VeroWhite ramp; graded: a gradient
        color = composition.css_background(material)
    return f'<span class="swatch" style="background:{esc(color)}"></span>'


def _design_html(entry: Entry, lib: MaterialLibrary) -> str:
    d, sim, chk = entry.design, entry.sim, entry.checks
    _, status = nominal_status(entry)
    anchor = esc(f"d-{entry.dirname}")
    parts = [f'<section class="design" id="{anchor}">', f"<h2>{esc(d.name)}</h2>"]
    label = paper_label(entry)
    if label:
        parts.append(f'<p class="paper">{esc(label[:1].upper() + label[1:])} (Mao et al., Sci. Rep. 2015).</p>')
    if d.description:
        parts.append(f'<p class="desc">{esc(d.description)}</p>')
    cls, _ = nominal_cell(entry)
    jam = printed_jam(entry)
    marginal = "" if jam is None else (f" Printed parts jam under scatter: jam probability {100 * jam:.1f} % in "
                                       f"{entry.checks['robust']['samples']} samples (foldprint check).")
    parts.append(f'<p class="status {cls}">Nominal fold: {esc(status + marginal)}</p>')
    passes, verdict = check_verdict(entry)
    parts.append(f'<p class="status {"ok" if passes else "fail"}">{esc(verdict)}</p>')
    if entry.viewer is not None:
        parts.append(f'<p class="viewer"><a class="button" href="{esc(entry.viewer.href)}">Open the interactive '
                     f'3D viewer</a> <span class="muted">(orbit, zoom, scrub the fold; programmed and permanent '
                     f'states{"; the worst scatter sample" if entry.worst is not None else ""}; '
                     f'{esc(_size(entry.viewer.size))} page)</span></p>')
    elif entry.viewer_note:
        parts.append(f'<p class="muted">{esc(entry.viewer_note)}</p>')
    kind = "planar strip (side view)" if d.is_planar_strip else "3D crease pattern"
    fold = (f"{fmt_s(entry.fold_time)} (every hinge at 98 %)" if entry.fold_time is not None
            else "\u2014 (does not complete)")
    parts.append(
        "<table><tbody>"
        f"<tr><th>bath</th><td>{sim['temperature_c']:g} \u00b0C</td></tr>"
        f"<tr><th>fold time</th><td>{esc(fold)}</td></tr>"
        f"<tr><th>structure</th><td>{len(d.panels)} panels, {len(d.hinges)} hinges, {esc(kind)}</td></tr>"
        f"<tr><th>model</th><td>{esc(HINGE_MODEL_TEXT.get(sim['hinge_model'], sim['hinge_model'] + ' hinges'))}; "
        f"collision check {esc(sim['method'])}, "
        f"after contact: {esc(sim['after_contact'])}, dt {esc(sim['dt_s'])} s</td></tr>"
        + (f"<tr><th>jam probability</th><td>{esc(jam_text(entry.mc))} in {entry.mc['samples']} samples"
           "</td></tr>" if entry.mc is not None else "")
        + "</tbody></table>")
    if entry.contacts:
        rows = "".join(f"<tr><td>{esc(a)}\u2013{esc(b)}</td><td class=\"num\">{seconds(t)}</td><td>{esc(m)}</td></tr>"
                       for a, b, t, m in entry.contacts)
        parts.append("<h3>Contacts</h3><table><thead><tr><th>panels</th><th>time</th><th>found by</th>"
                     f"</tr></thead><tbody>{rows}</tbody></table>")
    parts += _paper_html(entry)
    parts += _hinges_and_goals(d, sim, lib)
    parts += _findings_html(chk)
    parts.append(mc_html(entry))
    parts.append("<h3>Pictures</h3>")
    parts.append('<div class="pics">' + "".join(_img_html(i) for i in entry.images) + "</div>")
    parts.append("<h3>Files</h3><ul>")
    parts.extend(_link_html(link) for link in entry.files)
    parts.extend(_link_html(link) for link in entry.data_links)
    parts.append("</ul>")
    if entry.export_note:
        parts.append(f'<p class="status fail">{esc(entry.export_note)}</p>')
    parts.append("</section>")
    return "\n".join(parts)


def _paper_html(entry: Entry) -> list[str]:
    """What the paper says about the structure beside the model's value (check.json's
    ``paper``: the statements the template links, as ``foldprint check`` prints them)."""
    lines = entry.checks.get("paper") or []
    if not lines:
        return []
    rows = []
    for p in lines:
        paper = "" if p["paper_s"] is None else p["paper"]
        model = seconds(p["model_s"])
        ratio = "" if p["ratio"] is None else f"{p['ratio']:.2f}"
        rows.append(f"<tr><td>{esc(p['figure'])}</td><td>{esc(p['what'])}<blockquote>\u201c{esc(p['quote'])}"
                    f"\u201d</blockquote></td><td class=\"num\">{esc(paper)}</td><td class=\"num\">{esc(model)}</td>"
                    f"<td class=\"num\">{esc(ratio)}</td><td>{esc(p['verdict'])}{esc(_read_as(p))} \u2014 "
                    f"{esc(p['model'])}</td></tr>")
    return ["<h3>The paper beside the model</h3><table><thead><tr><th>figure</th><th>the paper says</th>"
            "<th>paper</th><th>model</th><th>model / paper</th><th>verdict</th></tr></thead>"
            f"<tbody>{''.join(rows)}</tbody></table>",
            '<p class="muted">The paper\u2019s times are read off video frames to the half second; each '
            "verdict names the interval its words are read as (docs/structure-timings.md).</p>"]


def _read_as(p: dict) -> str:
    """" (read as 6.5-7.5 s, +/-0.5 s)" beside a verdict on a number; "" otherwise."""
    r = p.get("reading")
    if not r or p["verdict"] not in ("meets", "misses"):
        return ""
    return f" ({r['read_as']})"


def _hinges_and_goals(d, sim: dict, lib: MaterialLibrary) -> list[str]:
    """The hinge table and the goal table of a design section."""
    parts = []
    rows = []
    for h, hd in zip(d.hinges, sim["hinges"]):
        rows.append(f"<tr><td>{esc(h.id)}</td><td>{esc(h.panels[0])}\u2013{esc(h.panels[1])}</td>"
                    f"<td>{_swatch(lib, h.material)}{esc(h.material)}</td>"
                    f"<td class=\"num\">{hd['target_angle_deg']:g}\u00b0</td>"
                    + (f"<td class=\"num\">{esc(hinge_text(hd))}</td></tr>" if hinge_folds(hd) else  # a time
                       f"<td class=\"fail\">{esc(hinge_text(hd))}</td></tr>"))  # why not: words that may wrap
    parts.append("<h3>Hinges</h3><table><thead><tr><th>hinge</th><th>panels</th><th>material</th>"
                 "<th>target angle</th><th>fold time (98 %)</th></tr></thead>"
                 f"<tbody>{''.join(rows)}</tbody></table>")
    parts.append(_ramp_note(d))
    parts.append("<h3>Goals</h3>")
    if sim["goals"]:
        rows = []
        for g in sim["goals"]:
            what = f"{g['panel']} passes through holes[{g['hole']}] of {g['target']}" \
                if g["type"] == "pass_through" else g["type"]
            met = f"met at {seconds(g['time_s'])}" if g["met"] else (
                "passed out of order" if g["passes_s"] else "NOT met")
            rows.append(f"<tr><td>{esc(g['id'])}</td><td>{esc(what)}</td><td class=\"num\">{g['order']}</td>"
                        f"<td class=\"{'ok' if g['met'] else 'fail'}\">{esc(met)}</td></tr>")
        parts.append("<table><thead><tr><th>goal</th><th>what</th><th>order</th><th>result</th></tr>"
                     f"</thead><tbody>{''.join(rows)}</tbody></table>")
    else:
        parts.append('<p class="muted">No goals.</p>')
    return parts


def _findings_html(chk: dict) -> list[str]:
    """The design-rule findings of a design section: errors and warnings listed, notes folded."""
    parts = []
    counts = {s: sum(f["severity"] == s for f in chk["findings"]) for s in ("error", "warning", "info")}
    parts.append(f"<h3>Design-rule checks ({esc(chk['printer'])})</h3>")
    parts.append(f"<p>{counts['error']} error(s), {counts['warning']} warning(s), {counts['info']} note(s).</p>")

    def finding(f) -> str:
        hint = f' <span class="muted">\u2014 {esc(f["hint"])}</span>' if f.get("hint") else ""
        return (f'<li><span class="sev-{esc(f["severity"])}">{esc(f["severity"].upper())} {esc(f["code"])}</span> '
                f"{esc(f['message'])}{hint}</li>")

    def listed(fs) -> str:  # a code found on many hinges: its first few and a count (check.json has all)
        return "".join(finding(f) + (f'<li class="muted">{esc(f["code"])} {esc(more_findings(rest))} '
                                     "(check.json lists every one)</li>" if rest else "")
                       for f, rest in clip_by(fs, lambda f: f["code"]))

    serious = [f for f in chk["findings"] if f["severity"] in ("error", "warning")]
    if serious:
        parts.append("<ul>" + listed(serious) + "</ul>")
    info = [f for f in chk["findings"] if f["severity"] == "info"]
    if info:
        parts.append(f"<details><summary>{len(info)} note(s)</summary><ul>" + listed(info) + "</ul></details>")
    return parts


_LEGEND = """<dl class="legend">
<dt>design</dt><dd>the design file; for a structure of the paper, how the paper names it (Sample 1, Sample 2, the
figures) or which of its figures a variant of ours is after.</dd>
<dt>foldprint check</dt><dd>the verdict of <code>foldprint check</code> on the printed part: its exit status and the
codes of its errors (docs/checks.md).</dd>
<dt>nominal fold</dt><dd>the fold of the part as designed (every hinge at its nominal material, thickness and bath):
green, it completes; red, it does not (a collision, a hinge short of 98 %, a goal missed); amber, it completes but
check finds that printed parts, which scatter, jam (a marginal design).</dd>
<dt>fold time</dt><dd>when the last hinge of the nominal fold reaches 98 % of its angle.</dd>
<dt>first collision</dt><dd>the first two panels of the nominal fold to touch, and when.</dd>
<dt>jam probability</dt><dd>the share of check's scattered samples (printed parts and baths drawn from the scatter
model) that jam, with its 95 % interval.</dd>
<dt>check errors, warnings</dt><dd>how many of check's findings are errors and warnings.</dd>
</dl>"""


def page_html(entries: list[Entry], materials_img: Image, lib: MaterialLibrary, dt: float,
          samples: int = CHECK_SAMPLES, seed: int = CHECK_SEED) -> str:
    rows = []
    for en in entries:
        passes, _ = check_verdict(en)
        codes = ", ".join(dict.fromkeys(f["code"] for f in en.checks["findings"] if f["severity"] == "error"))
        first = (f"{esc(en.contacts[0][0])}\u2013{esc(en.contacts[0][1])} at {seconds(en.contacts[0][2])}"
                 if en.contacts else "none")
        ft = fmt_s(en.fold_time)
        jam = "not run" if en.mc is None else jam_text(en.mc)
        view = (f' <a class="muted" href="{esc(en.viewer.href)}">3D viewer</a>' if en.viewer is not None else "")
        cls, nominal = nominal_cell(en)
        label = paper_label(en)
        named = f'<br><span class="muted">{esc(label)}</span>' if label else ""
        failed = '<br><span class="sev-error">no print files: cannot be built</span>' if en.export_note else ""
        rows.append(f'<tr><td><a href="#{esc("d-" + en.dirname)}">{esc(en.design.name)}</a>{view}{named}{failed}</td>'
                    f'<td class="{"ok" if passes else "fail"}">'
                    + (f"passes (exit 0)" if passes else f"fails (exit 1): {esc(codes)}") + "</td>"
                    f'<td class="{cls}">{esc(nominal)}</td>'
                    f'<td class="num">{esc(ft)}</td><td>{first}</td><td class="num">{esc(jam)}</td>'
                    f'<td class="num">{en.checks["errors"]}</td><td class="num">{en.checks["warnings"]}</td></tr>')
    summary = ("<table><thead><tr><th>design</th><th>foldprint check</th><th>nominal fold</th><th>fold time</th>"
               "<th>first collision</th><th>jam probability (95 % CI)</th><th>check errors</th><th>warnings</th>"
               f"</tr></thead><tbody>{''.join(rows)}</tbody></table>" + _LEGEND)
    models = sorted({en.sim["hinge_model"] for en in entries})
    model_text = "; ".join(HINGE_MODEL_TEXT.get(m, f"{m} hinges") for m in models) or "no design"
    mc_text = (f"and folded again under manufacturing scatter (seed {seed}) until a sequential test knows its jam "
               f"verdict (at most {samples} samples per sigma scale): the same check, test and seed as "
               "<code>foldprint check</code>, whose verdict (exit status and error codes) the summary gives"
               if samples else
               "without the Monte-Carlo jam probability (0 samples; <code>foldprint check</code> runs it)")
    body = "\n".join(_design_html(en, lib) for en in entries)
    ours = [(en.design.paper.label, en.design.name) for en in entries
            if en.design.paper is not None and en.design.paper.statements]
    paper_text = ("The paper's own structures: " + "; ".join(f"{esc(lbl)}: <code>{esc(n)}</code>" for lbl, n in ours)
                  + ". Each of their sections quotes what the paper says beside the model's value. ") if ours else ""
    return f"""<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<meta name="generator" content="foldprint {esc(__version__)}">
<title>foldprint gallery</title>
<style>{_CSS}</style>
</head>
<body>
<header>
<h1>foldprint gallery</h1>
<p>Sequentially self-folding structures printed with digital shape-memory polymers (after Mao et al.,
Sci. Rep. 5, 13616, 2015): {len(entries)} design(s), simulated with {esc(model_text)}
(time step {dt:g} s, first contacts refined between time steps), checked against the design rules
{mc_text}. The paper's point-hinge reduced-order model is a comparison mode
(<code>foldprint simulate --hinge-model point</code>). {paper_text}Generated by foldprint {esc(__version__)}.</p>
</header>
<main>
<h2 id="summary">Summary</h2>
{summary}
<h2 id="materials">Materials</h2>
{_img_html(materials_img)}
{body}
</main>
</body>
</html>
"""
