"""The gallery's Monte-Carlo tables: each design's samples as data (``samples.json``:
every sample's outcome, the worst sample's drawn parameters) and as the page's HTML."""

from __future__ import annotations

from ...checks.report import jam_estimate_text, jam_test_json, jam_test_text, seconds
from ...model.design import Design
from .entry import Entry, esc


def mc_summary(robust) -> dict:
    """What the page shows of the Monte-Carlo: the estimate, and per sample its outcome."""
    import numpy as np

    pairs = []
    for (a, b), count in robust.collisions():
        times = sorted(o.time for o in robust.outcomes if o.pair == (a, b))
        pairs.append({"pair": [a, b], "count": count, "first_s": times[0],
                      "median_s": float(np.median(times)), "last_s": times[-1]})
    reasons = {k: sum(o.reason == k for o in robust.outcomes) for k in ("collision", "goal", "unfolded")}
    return {"samples": robust.samples, "seed": robust.seed, "hinge_model": str(robust.hinge_model.value),
            "jams": robust.jams, "jam_probability": float(robust.jam_probability),
            "ci95": [float(x) for x in robust.ci95], "interval": robust.interval_name,
            "text": jam_estimate_text(robust), "how": jam_test_text(robust),
            "test": jam_test_json(robust.decision), "failures": reasons, "pairs": pairs,
            "fold_time_s": robust.fold_time_percentiles(),
            "outcomes": [{"sample": k, "jammed": o.jammed, "reason": o.reason,
                          "pair": None if o.pair is None else list(o.pair),
                          "contact_s": o.time, "fold_time_s": o.fold_time}
                         for k, o in enumerate(robust.outcomes)]}


def worst_json(replay, design: Design) -> dict:
    """The worst sample: why it is the worst, its replayed verdict and its drawn parameters."""
    import dataclasses

    import numpy as np

    from ...render.viewer import worst_text

    o, res = replay.outcome, replay.result
    c = res.first_collision
    params = {}
    for f in dataclasses.fields(replay.sample):
        v = getattr(replay.sample, f.name)
        params[f.name] = [float(x) for x in np.ravel(v)] if np.ndim(v) else float(v)
    return {"sample": replay.index, "why": worst_text(replay), "jammed": o.jammed, "reason": o.reason,
            "pair": None if o.pair is None else list(o.pair), "contact_s": o.time, "fold_time_s": o.fold_time,
            "replay_agrees": bool(replay.agrees),
            "replay": {"completed": bool(res.completed), "fold_time_s": res.fold_time,
                       "first_collision": None if c is None else {"panels": list(c.panels), "time_s": float(c.time)}},
            "hinges": [h.id for h in design.hinges], "parameters": params}


def _pct(p: float) -> str:
    return f"{100 * p:.1f} %"


def jam_text(mc: dict) -> str:
    """The jam probability as ``foldprint check`` prints it (one writer:
    :func:`foldprint.checks.report.jam_estimate_text`)."""
    return mc["text"]


def mc_html(entry: Entry) -> str:
    """The design's Monte-Carlo: estimate, first-colliding pairs, fold times, worst sample."""
    mc = entry.mc
    if mc is None:
        return ('<h3>Under manufacturing scatter</h3><p class="muted">Not run (0 samples): no jam '
                "probability.</p>")
    n, f = mc["samples"], mc["failures"]
    ways = ", ".join(f"{k} {w}" for w, k in (("collide", f["collision"]), ("miss a goal", f["goal"]),
                                               ("do not finish folding", f["unfolded"])) if k)
    parts = [f"<h3>Under manufacturing scatter ({n} samples, seed {mc['seed']})</h3>",
             f"<p>Jam probability <strong>{esc(jam_text(mc))}</strong>"
             + (f" ({esc(ways)})" if ways else "") + f"; {esc(mc['how'])}. The same test, samples, seed and time "
             f"step as <code>foldprint check</code>; each sample draws Tg, thickness and heat transfer per hinge "
             f"and the bath temperature, and folds the printed part ({esc(mc['hinge_model'])} hinges).</p>"]
    if mc["pairs"]:
        rows = "".join(
            f"<tr><td>{esc(p['pair'][0])}\u2013{esc(p['pair'][1])}</td><td class=\"num\">{p['count']}</td>"
            f"<td class=\"num\">{_pct(p['count'] / n)}</td><td class=\"num\">{seconds(p['first_s'])}</td>"
            f"<td class=\"num\">{seconds(p['median_s'])}</td><td class=\"num\">{seconds(p['last_s'])}</td></tr>"
            for p in mc["pairs"])
        parts.append("<table><caption>First-colliding panel pairs</caption><thead><tr><th>panels</th>"
                     "<th>samples</th><th>share</th><th>earliest contact</th><th>median</th><th>latest</th>"
                     f"</tr></thead><tbody>{rows}</tbody></table>")
    else:
        parts.append("<p>No sample collides.</p>")
    ft = [o["fold_time_s"] for o in mc["outcomes"] if o["fold_time_s"] is not None]
    if ft:
        p = mc["fold_time_s"]
        parts.append("<table><caption>Fold time of the samples that complete</caption><thead><tr><th>samples</th>"
                     "<th>fastest</th><th>5 %</th><th>median</th><th>95 %</th><th>slowest</th></tr></thead>"
                     f"<tbody><tr><td class=\"num\">{len(ft)}</td><td class=\"num\">{seconds(min(ft))}</td>"
                     f"<td class=\"num\">{seconds(p['p5'])}</td><td class=\"num\">{seconds(p['p50'])}</td>"
                     f"<td class=\"num\">{seconds(p['p95'])}</td><td class=\"num\">{seconds(max(ft))}</td></tr>"
                     "</tbody></table>")
    else:
        parts.append("<p>No sample completes its fold.</p>")
    w = entry.worst
    if w is not None:
        link = (f' <a href="{esc(entry.viewer.href)}#run=worst">Replay it in the 3D viewer</a>.'
                if entry.viewer is not None else "")
        rep = w["replay"]
        again = ("completes" if rep["completed"] else "does not complete") + (
            f", first contact {rep['first_collision']['panels'][0]}\u2013{rep['first_collision']['panels'][1]} "
            f"at {seconds(rep['first_collision']['time_s'])}" if rep["first_collision"] else "")
        note = "" if w["replay_agrees"] else " (the replay does not give the recorded outcome: a bug, please report)"
        prm = w["parameters"]
        rows = []
        for k, hid in enumerate(w["hinges"]):
            cells = "".join(f'<td class="num">{esc(_param(name, vals[k]))}</td>' for name, vals in prm.items()
                            if isinstance(vals, list))
            rows.append(f"<tr><td>{esc(hid)}</td>{cells}</tr>")
        heads = "".join(f"<th>{esc(_PARAM_NAMES.get(name, name))}</th>" for name, vals in prm.items()
                        if isinstance(vals, list))
        shared = ", ".join(f"{_PARAM_NAMES.get(name, name)} {_param(name, v)}" for name, v in prm.items()
                           if not isinstance(v, list))
        parts.append(f"<p><strong>Worst sample: #{w['sample']}</strong>, {esc(w['why'])}; replayed, it "
                     f"{esc(again)}{esc(note)}.{link}</p>"
                     f"<details><summary>its drawn parameters ({esc(shared)})</summary><table><thead><tr>"
                     f"<th>hinge</th>{heads}</tr></thead><tbody>{''.join(rows)}</tbody></table></details>")
    return "\n".join(parts)


_PARAM_NAMES = {"tg_shift_c": "Tg shift", "thickness_mm": "thickness", "h_scale": "heat-transfer factor",
                "bath_c": "bath", "h_part": "part heat-transfer factor"}


def _param(name: str, v: float) -> str:
    if name.endswith("_c"):
        return f"{v:+.2f} \u00b0C" if name == "tg_shift_c" else f"{v:.2f} \u00b0C"
    if name.endswith("_mm"):
        return f"{v:.3f} mm"
    return f"\u00d7{v:.3f}"
