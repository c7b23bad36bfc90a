"""The gallery's one HTML page (``index.html``): the summary table, the materials chart
and a section per design (inline CSS, no scripts, relative links)."""

from __future__ import annotations

from .. import __version__
from ..core.constants import CHECK_SAMPLES, CHECK_SEED
from ..model import composition
from ..model.materials import MaterialLibrary
from ..checks.report import seconds
from .gallery_entry import Entry, Image, Link, esc, fmt_s
from .gallery_samples import jam_text, mc_html

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
td.num { text-align: right; font-variant-numeric: tabular-nums; }
figure { margin: 0.8em 0; }
figcaption { color: #555; font-size: 0.9em; }
img { max-width: 100%; height: auto; border: 1px solid #eee; }
.status { padding: 0.5em 0.8em; border-radius: 4px; font-weight: 600; }
.ok { background: #e6f4ea; color: #1e6b34; } .fail { background: #fdecea; color: #9b1c1c; }
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
    ok, status = nominal_status(entry)
    anchor = esc(f"d-{entry.dirname}")
    parts = [f'<section class="design" id="{anchor}">', f"<h2>{esc(d.name)}</h2>"]
    if d.description:
        parts.append(f'<p class="desc">{esc(d.description)}</p>')
    parts.append(f'<p class="status {"ok" if ok else "fail"}">Nominal fold: {esc(status)}</p>')
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
        parts.append(f'<p class="muted">{esc(entry.export_note)}</p>')
    parts.append("</section>")
    return "\n".join(parts)


def _hinges_and_goals(d, sim: dict, lib: MaterialLibrary) -> list[str]:
    """The hinge table and the goal table of a design section."""
    parts = []
    rows = []
    for h, hd in zip(d.hinges, sim["hinges"]):
        rows.append(f"<tr><td>{esc(h.id)}</td><td>{esc(h.panels[0])}\u2013{esc(h.panels[1])}</td>"
                    f"<td>{_swatch(lib, h.material)}{esc(h.material)}</td>"
                    f"<td class=\"num\">{hd['target_angle_deg']:g}\u00b0</td>"
                    f"<td class=\"num\">{esc(fmt_s(hd['fold_time_s']))}</td></tr>")
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

    serious = [f for f in chk["findings"] if f["severity"] in ("error", "warning")]
    if serious:
        parts.append("<ul>" + "".join(finding(f) for f in serious) + "</ul>")
    info = [f for f in chk["findings"] if f["severity"] == "info"]
    if info:
        parts.append(f"<details><summary>{len(info)} note(s)</summary><ul>"
                     + "".join(finding(f) for f in info) + "</ul></details>")
    return parts


def page_html(entries: list[Entry], materials_img: Image, lib: MaterialLibrary, dt: float,
          samples: int = CHECK_SAMPLES, seed: int = CHECK_SEED) -> str:
    rows = []
    for en in entries:
        ok, _ = nominal_status(en)
        passes, _ = check_verdict(en)
        codes = ", ".join(dict.fromkeys(f["code"] for f in en.checks["findings"] if f["severity"] == "error"))
        first = (f"{esc(en.contacts[0][0])}\u2013{esc(en.contacts[0][1])} at {seconds(en.contacts[0][2])}"
                 if en.contacts else "none")
        ft = fmt_s(en.fold_time)
        jam = "not run" if en.mc is None else jam_text(en.mc)
        view = (f' <a class="muted" href="{esc(en.viewer.href)}">3D viewer</a>' if en.viewer is not None else "")
        rows.append(f'<tr><td><a href="#{esc("d-" + en.dirname)}">{esc(en.design.name)}</a>{view}</td>'
                    f'<td class="{"ok" if passes else "fail"}">'
                    + (f"passes (exit 0)" if passes else f"fails (exit 1): {esc(codes)}") + "</td>"
                    f'<td class="{"ok" if ok else "fail"}">{"completes" if ok else "does not complete"}</td>'
                    f'<td class="num">{esc(ft)}</td><td>{first}</td><td class="num">{esc(jam)}</td>'
                    f'<td class="num">{en.checks["errors"]}</td><td class="num">{en.checks["warnings"]}</td></tr>')
    summary = ("<table><thead><tr><th>design</th><th>foldprint check</th><th>nominal fold</th><th>fold time</th>"
               "<th>first collision</th><th>jam probability (95 % CI)</th><th>check errors</th><th>warnings</th>"
               f"</tr></thead><tbody>{''.join(rows)}</tbody></table>")
    models = sorted({en.sim["hinge_model"] for en in entries})
    model_text = "; ".join(HINGE_MODEL_TEXT.get(m, f"{m} hinges") for m in models) or "no design"
    mc_text = (f"and folded again under manufacturing scatter (seed {seed}) until a sequential test knows its jam "
               f"verdict (at most {samples} samples per sigma scale): the same check, test and seed as "
               "<code>foldprint check</code>, whose verdict (exit status and error codes) the summary gives"
               if samples else
               "without the Monte-Carlo jam probability (0 samples; <code>foldprint check</code> runs it)")
    body = "\n".join(_design_html(en, lib) for en in entries)
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
(<code>foldprint simulate --hinge-model point</code>). Generated by foldprint {esc(__version__)}.</p>
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
