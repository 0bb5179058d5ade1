"""The scene report page (``index.html`` beside ``report.json``): one page a person reads.

Sections: a summary, accuracy against time (the plot shown large, a sentence under it saying
what it shows), the methods with the papers' figures beside ours, the sweep, the hardest regions
(zoomed insets), the images and error maps, then the database, the reference, the plan and the
settings as readable tables. Every table sorts on a click of its header (inline script).
"""
from __future__ import annotations

from .page_parts import PAGE_STYLE, SORT_SCRIPT, esc, figure, fmt, key_values, sortable
from .knobs import REFERENCE
from .metrics import CONVERGED_FLOOR
from .papers import published_for, published_range

__all__ = ["render_page"]

TIMING_COLUMNS = (("time_ms", "time [ms]"), ("device_ms", "device [ms]"), ("transfer_ms", "transfers [ms]"),
                  ("host_ms", "host [ms]"), ("compile_ms", "set-up [ms] (excluded)"),
                  ("prepare_ms", "prepare [ms] (excluded)"))


def _camera_line(camera: dict) -> str:
    parts = [str(camera.get("lens", "?"))]
    if "focal_length_mm" in camera:
        parts.append(f"{camera['focal_length_mm']:g} mm")
    if "f_number" in camera:
        parts.append(f"f/{camera['f_number']:g}")
    if "focus_distance_m" in camera:
        parts.append(f"focus {camera['focus_distance_m']:g} m")
    return ", ".join(parts)


def _summary(report: dict) -> str:
    scene, methods = report["scene"], report["methods"]
    w, h = scene["resolution"]
    ref = report.get("reference", {})
    text = (f"{w}&times;{h} px, {esc(_camera_line(scene['camera']))} camera; effects: "
            + esc(", ".join(f"{k} {v}" for k, v in report["plan"]["effects"].items() if v != "none")) + ". ")
    if "none" in ref:   # no reference: the images are shown unscored
        return f"<p class='lead'>{text}No reference: {esc(ref['none'])}.</p>"
    text += (f"Every figure is measured against the path-traced reference ({esc(', '.join(ref.get('steps', [])))}, "
             f"{fmt(ref.get('reference_spp'))} spp) on the tonemap <code>{esc(report['tonemap'])}</code>.")
    if methods:
        best = max(methods, key=lambda n: methods[n]["ssim"])
        fast = min(methods, key=lambda n: methods[n]["time_ms"])
        text += (f" Most accurate: <b>{esc(best)}</b> (SSIM {methods[best]['ssim']:.3f}); fastest: "
                 f"<b>{esc(fast)}</b> ({methods[fast]['time_ms']:.3g} ms).")
    floor = ref.get("noise_floor")
    if floor:
        text += (f" Two references with independent seeds agree at SSIM {floor['ssim']:.3f} and PSNR "
                 f"{floor['psnr']:.2f} dB: the reference's own noise, which no method can beat.")
        if floor["ssim"] < CONVERGED_FLOOR:
            text += (f" <b>Not converged enough to validate</b>: below {CONVERGED_FLOOR} its noise is as large "
                     "as the methods' errors, so their SSIM differences are not to be trusted; render more "
                     "spp (<code>[render] reference_spp</code>) or an adaptive reference "
                     "(<code>[render] reference_adaptive</code>).")
    elif ref.get("noise_floor_skipped"):
        text += f" The reference's noise floor was not measured: {esc(ref['noise_floor_skipped'])}."
    adaptive = ref.get("adaptive")
    if adaptive:
        text += (f" The reference is adaptive: {fmt(adaptive['base_spp'])} spp everywhere plus "
                 f"{fmt(adaptive['extra_spp'])} spp (frame average) on the {fmt(adaptive['tiles_refined'])} "
                 f"noisiest {fmt(adaptive['tile_px'])}-px tiles (up to {fmt(adaptive['tile_spp_max'])} spp), "
                 "found by a "
                 f"{fmt(adaptive['pilot_spp'])}-spp pilot that is not in the image.")
    return f"<p class='lead'>{text}</p>"


def _accuracy_section(report: dict) -> str:
    sweep = report.get("sweep")
    parts = ["<h2 id='accuracy'>Accuracy against time</h2>"]
    if sweep and sweep.get("plot"):
        parts.append(f"<div class='plot'><img src='{esc(sweep['plot'])}' alt='accuracy against time, every knob'></div>")
        parts += [f"<p class='caption'>{esc(s)}</p>" for s in sweep["sentences"].values()]
        parts.append("<p class='caption'>Each line is one method with one knob turned (its values beside the "
                     "points); the ringed point is the report's own setting; the grey steps are the Pareto "
                     "front (no point is both faster and more accurate). The path tracer's points are the "
                     "reference re-rendered with fewer samples and another seed; their time is its wall "
                     "clock.</p>")
    for title, plot in report.get("plots", {}).items():
        if sweep and sweep.get("plot"):
            break   # the sweep's plot holds these points too
        parts.append(f"<div class='plot'><img src='{esc(plot['image'])}' alt='{esc(title)}'></div>")
        parts += [f"<p class='caption'>{esc(s)}</p>" for s in plot["sentences"]]
    return "".join(parts)


def _methods_section(report: dict) -> str:
    methods = report["methods"]
    nc = all(m.get("noise_corrected_psnr", None) is not None or "noise_corrected_mse" in m for m in methods.values()) \
        and bool(report.get("reference", {}).get("noise_floor"))
    heads = ["method", "pass"] + [h for _, h in TIMING_COLUMNS] + ["SSIM", "PSNR [dB]"]
    heads += ["noise-corrected MSE", "noise-corrected PSNR [dB]"] if nc else []
    heads += ["speed-up vs timing reference", "published (paper)"]
    rows = []
    for name, m in methods.items():
        row = [name, m.get("pass")] + [m.get(c) for c, _ in TIMING_COLUMNS] + [m["ssim"], m["psnr"]]
        if nc:
            row.append(m.get("noise_corrected_mse"))
            row.append(m.get("noise_corrected_psnr") if m.get("noise_corrected_psnr") is not None else "below the noise")
        row += [m.get("speedup_vs_timing_reference"), published_range(name) or None]
        rows.append(row)
    timing = report.get("timing", {})
    notes = "".join(f"<li><code>{esc(k)}</code>: {esc(v)}</li>" for k, v in timing.items()) \
        if isinstance(timing, dict) else ""
    return ("<h2 id='methods'>Methods</h2>" + sortable(heads, rows)
            + f"<details><summary>What the timing columns mean</summary><ul>{notes}</ul></details>"
            + _published_table(report))


def _published_table(report: dict) -> str:
    """One row per scene a paper measured, our methods' time and accuracy as columns; this
    scene's figures in the last row (highlighted)."""
    methods = {name: m for name, m in report["methods"].items() if published_for(name)}
    if not methods:
        return ""
    rows: dict[tuple, dict] = {}
    for name in methods:
        for r in published_for(name):
            rows.setdefault((r["paper"], r["where"], r["scene"], r["setting"]), {})[name] = r
    psnr = {n: any(r.get(n, {}).get("psnr") is not None for r in rows.values()) for n in methods}
    heads = ["paper", "where", "scene", "setting"]
    for n in methods:
        heads += [f"{n} time [ms]", f"{n} SSIM"] + ([f"{n} PSNR [dB]"] if psnr[n] else [])
    body = []
    for (paper, where, scene, setting), by in rows.items():
        row = [paper, where, scene, setting]
        for n in methods:
            r = by.get(n, {})
            row += [r.get("time_ms"), r.get("ssim")] + ([r.get("psnr")] if psnr[n] else [])
        body.append(row)
    ours = ["ours", "this report", report["scene"]["name"], "this CPU (PoCL)"]
    for n, m in methods.items():
        ours += [m["time_ms"], m["ssim"]] + ([m["psnr"]] if psnr[n] else [])
    body.append(ours)
    return ("<h3>The papers' figures beside ours</h3><p class='caption'>Their times are on their GPUs, ours on "
            "this CPU: compare accuracy, and time only as ratios within a row. Their scenes are not this one "
            "unless the names agree; ours is the green row.</p>"
            + sortable(heads, body, [""] * (len(body) - 1) + ["front"], digits=3))


def _sweep_section(report: dict) -> str:
    sweep = report.get("sweep")
    if not sweep:
        return ""
    knobs = sweep["knobs"]
    heads = ["method", "knob", "sets", "value", "report's value", "time [ms]", "SSIM", "PSNR [dB]",
             "noise-corrected PSNR [dB]", "on the SSIM front", "on the PSNR front", "timed by"]
    rows, classes = [], []
    for p in sweep["points"]:
        knob = knobs.get(p["knob"], {}) if p["knob"] else {}
        rows.append([p["method"], knob.get("label", "as planned"), p.get("key"), p.get("value"), p.get("base"),
                     p["time_ms"], p["ssim"], p["psnr"], p.get("noise_corrected_psnr"), p["on_front"]["ssim"],
                     p["on_front"]["psnr"], "wall clock" if p["method"] == REFERENCE else "runtime contract"])
        classes.append(" ".join(c for c, on in (("front", p["on_front"]["ssim"]), ("base", p.get("base"))) if on))
    skipped = "".join(f"<li><b>{esc(s['method'])}</b> / {esc(s['knob'])}: {esc(s['reason'])}</li>"
                      for s in sweep["skipped"])
    return ("<h2 id='sweep'>The sweep, point by point</h2><p class='caption'>Green rows are on the SSIM "
            "Pareto front; bold methods mark the report's own setting of the knob. Times are the runtime's "
            "contract (median <code>time_ms</code> of timed calls after a warm-up) except the path tracer's, "
            "the wall clock of its render.</p>"
            + sortable(heads, rows, classes, table_id="sweep-table")
            + (f"<details><summary>{len(sweep['skipped'])} knob(s) that do not apply, and why</summary>"
               f"<ul>{skipped}</ul></details>" if skipped else ""))


def _insets_section(report: dict) -> str:
    insets = report.get("insets")
    if not insets or not insets.get("regions"):
        return ""
    parts = [f"<h2 id='insets'>Hardest regions</h2><p class='caption'>{esc(insets['about'])}.</p>",
             f"<div class='overview'>{figure(insets['overview'], 'the regions on the reference')}</div>"]
    for i, region in enumerate(insets["regions"], 1):
        parts.append(f"<h3>Region {i}: rows {region['row']}-{region['row'] + region['size'] - 1}, columns "
                     f"{region['col']}-{region['col'] + region['size'] - 1} (x{region['zoom']})</h3><div class='strip'>")
        for name, src in region["crops"].items():
            err = region["method_errors"].get(name)
            caption = name if err is None else f"{name}: mean |error| {err:.3f}"
            parts.append(figure(src, caption))
        parts.append("</div>")
    return "".join(parts)


def _images_section(report: dict) -> str:
    figs = [figure(src, name) for name, src in report["images"].items()]
    pairs = []
    for name, m in report["methods"].items():   # each method beside its error map
        if m.get("ssim") is None:   # no reference: no score, no error map
            pairs.append("<div class='pair'>" + figure(m["image"], f"{name}: {m['time_ms']:.3g} ms (unscored)") + "</div>")
            continue
        pairs.append("<div class='pair'>" + figure(m["image"], f"{name}: SSIM {m['ssim']:.3f}, {m['time_ms']:.3g} ms")
                     + figure(m["error_image"], f"{name}: |error| x{m['error_scale']:g} (bright = wrong)") + "</div>")
    return ("<h2 id='images'>Images and error maps</h2><div class='grid'>" + "".join(figs) + "</div>"
            "<div class='grid'>" + "".join(pairs) + "</div>")


DB_ROWS = (("model", "model"), ("samples", "PSF samples"), ("psf_resolution", "PSF edge [px]"),
           ("spreadlets", "spreadlets"), ("mean_spreadlets_per_sample", "spreadlets per sample"),
           ("basis", "spreadlet basis"), ("fast_track", "fast-track (dense) samples"),
           ("mean_sparsity", "mean sparsity"), ("sparse_only_sparsity", "mean sparsity of the sparse samples"),
           ("row_spreadlets", "row differences (dual basis)"),
           ("row_sparse_only_sparsity", "mean sparsity of the sparse row samples (dual basis)"),
           ("mean_ssim", "mean SSIM of the stored PSFs"), ("mean_l1", "mean L1"),
           ("file_bytes", "file size [bytes]"), ("reused", "reused from the cache"),
           ("build_seconds", "build [s]"), ("rays", "rays traced"), ("trace_Mrays_per_s", "tracing [M rays/s]"),
           ("sparsify_seconds", "sparsify [s]"), ("path", "file"))


def _database_section(report: dict) -> str:
    dbs = report.get("database") or {}
    if not dbs:
        return ""
    names = list(dbs)
    rows = [[label] + [dbs[n].get(key) for n in names] for key, label in DB_ROWS]
    space = [["PSF space"] + [", ".join(f"{a} in [{lo:g}, {hi:g}]" for a, (lo, hi) in
                                        zip(dbs[n]["psf_space"]["names"], dbs[n]["psf_space"]["ranges"]))
                              for n in names]] if all("psf_space" in dbs[n] for n in names) else []
    head = "".join(f"<th>{esc(n)}</th>" for n in names)
    body = "".join("<tr>" + f"<th class='text'>{esc(r[0])}</th>" + "".join(f"<td>{fmt(v)}</td>" for v in r[1:])
                   + "</tr>" for r in space + rows)
    configs = "".join(f"<details><summary>{esc(n)}: its configuration</summary>"
                      f"{key_values(dbs[n].get('params', {}).get('config', {}))}</details>" for n in names)
    return f"<h2 id='database'>PSF database</h2><table><tr><th></th>{head}</tr>{body}</table>{configs}"


def _reference_section(report: dict) -> str:
    ref = dict(report.get("reference") or {})
    floor = ref.pop("noise_floor", None)
    rows = [("steps", ", ".join(ref.pop("steps", []))), ("reference spp", ref.pop("reference_spp", None)),
            ("input spp", ref.pop("input_spp", None)), ("reference render [s]", ref.pop("reference_s", None)),
            ("input render [s]", ref.pop("input_s", None)), ("rendered on", ref.pop("reference_on", None))]
    if floor:
        rows += [("noise floor SSIM", floor["ssim"]), ("noise floor PSNR [dB]", floor["psnr"]),
                 ("noise floor seeds", floor["seeds"])]
    else:
        rows += [("noise floor", ref.pop("noise_floor_skipped", "not measured"))]
    adaptive = ref.pop("adaptive", None)
    if adaptive:
        rows += [(f"adaptive: {k.replace('_', ' ')}", v) for k, v in adaptive.items()]
    rows += list(ref.items())
    body = "".join(f"<tr><th class='text'>{esc(k)}</th><td class='text'>{fmt(v)}</td></tr>" for k, v in rows)
    return f"<h2 id='reference'>Reference</h2><table>{body}</table>"


def _plan_section(report: dict) -> str:
    plan = report["plan"]
    effects = "".join(f"<tr><th class='text'>{esc(k)}</th><td class='text'>{esc(v)}</td></tr>"
                      for k, v in plan["effects"].items())
    skipped = "".join(f"<li>{esc(s)}</li>" for s in plan["skipped"])
    options = "; ".join(f"{label}: " + ", ".join(f"{k} = {v}" for k, v in o.items())
                        for label, o in plan.get("pass_options", {}).items())
    return (f"<h2 id='plan'>Plan</h2><table>{effects}<tr><th class='text'>PSF models</th><td class='text'>"
            f"{fmt(plan['psf_models'])}</td></tr><tr><th class='text'>runtime passes</th><td class='text'>"
            f"{fmt(plan['runtime_passes'])}</td></tr>"
            + (f"<tr><th class='text'>pass options</th><td class='text'>{esc(options)}</td></tr>" if options else "")
            + f"</table><p>Not done, and why:</p><ul>{skipped}</ul>")


def render_page(report: dict) -> str:
    """The report page of a scene's report.json dictionary (see :mod:`lab.report.build`)."""
    scene = report["scene"]
    nav = "".join(f"<a href='#{a}'>{t}</a>" for a, t in (
        ("accuracy", "accuracy vs time"), ("methods", "methods"), ("sweep", "sweep"), ("insets", "hardest regions"),
        ("images", "images"), ("database", "database"), ("reference", "reference"), ("plan", "plan"),
        ("settings", "settings")) if a != "sweep" or report.get("sweep"))
    parts = [f"<!doctype html><html lang='en'><head><meta charset='utf-8'><title>splatlab: {esc(scene['name'])}</title>"
             f"<style>{PAGE_STYLE}</style></head><body><nav>{nav}</nav><main>",
             f"<h1>splatlab report: {esc(scene['name'])}</h1>", _summary(report)]
    if report.get("regressions"):
        items = "".join(f"<li>{esc(r)}</li>" for r in report["regressions"])
        parts.append(f"<h2 class='bad'>Regressions against the baseline</h2><ul class='bad'>{items}</ul>")
    parts += [_accuracy_section(report), _methods_section(report), _sweep_section(report),
              _insets_section(report), _images_section(report), _database_section(report),
              _reference_section(report), _plan_section(report),
              "<h2 id='settings'>Settings and machine</h2>"]
    for title, key in (("Settings", "settings"), ("Machine", "machine")):
        if key in report:
            parts.append(f"<details><summary>{title}</summary>{key_values(report[key])}</details>")
    parts.append(f"<p class='caption'>Created {esc(report.get('created', ''))}; scene file "
                 f"<code>{esc(scene['path'])}</code>; every figure is in <a href='report.json'>report.json</a>.</p>")
    parts.append(f"</main><script>{SORT_SCRIPT}</script></body></html>")
    return "\n".join(parts)
