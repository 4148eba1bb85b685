"""One self-contained HTML page per run: verdicts with their reasons, tables, notes and the run's figures.

Every command that writes a report folder (``run``, ``gnssdo --out``, ``swarm run --out``, ``stability --plot``,
``detect --report``, ``monitor --report``) describes its page as :class:`Section` s and calls
:func:`write_html`; the page embeds its PNGs as data URIs, so it can be mailed or archived alone, and sits
beside the PNGs and the JSON it was made from. A verdict is never shown without its reason
(:class:`Verdict`); :func:`mask_reason` words an ITU-T verdict (which limit, at which tau, by how much).
"""

from __future__ import annotations

import base64
import html
import math
from dataclasses import dataclass, field
from pathlib import Path

from chronofuse import __version__

__all__ = ["Verdict", "Section", "write_html", "mask_reason", "mask_verdicts", "ns"]


@dataclass(frozen=True)
class Verdict:
    """One verdict: what was judged, ``passed`` (True/False; None: not given, ``reason`` says why) and why."""

    subject: str
    passed: bool | None
    reason: str

    def __post_init__(self):
        if not self.reason.strip():
            raise ValueError(f"verdict {self.subject!r} has no reason")

    @property
    def word(self) -> str:
        return {True: "PASS", False: "FAIL", None: "NOT GIVEN"}[self.passed]


@dataclass
class Section:
    """A part of the page: a heading, verdicts, a table (header, rows), paragraphs and figures (PNG paths)."""

    title: str
    verdicts: list[Verdict] = field(default_factory=list)
    table: tuple[list[str], list[list]] | None = None
    notes: list[str] = field(default_factory=list)
    images: list[tuple[Path, str]] = field(default_factory=list)  # (PNG, caption)


def ns(seconds: float | None, digits: int = 1) -> str:
    """A time in seconds written in nanoseconds ("-" for none)."""
    if seconds is None or not math.isfinite(seconds):
        return "-"
    return f"{seconds * 1e9:.{digits}f} ns"


def _worst(part: dict) -> tuple[float, float, float] | None:
    """(tau, value, limit) of a mask check's most negative margin among the evaluated points; None if none."""
    best = None
    for tau, value, limit, margin, used in zip(part["tau"], part["value"], part["limit"], part["margin"],
                                               part["evaluated"]):
        if used and margin is not None and (best is None or margin < best[3]):
            best = (tau, value, limit, margin)
    return None if best is None else best[:3]


def mask_reason(verdict: dict) -> str:
    """Why a clock-class verdict (``ClockVerdict.to_dict()``) is what it is: for a failure, each failing
    limit with its worst observation interval and the excess over the limit; for a pass, the tightest margin."""
    failing, tightest = [], None
    for metric in ("mtie", "tdev"):
        part = verdict.get(metric)
        if not part:
            continue
        worst = _worst(part)
        if worst is None:
            continue
        tau, value, limit = worst
        bad = [t for t, ok, used in zip(part["tau"], part["passed_each"], part["evaluated"]) if used and not ok]
        label = metric.upper()
        if part.get("status", "pass" if part["passed"] else "fail") == "fail":
            failing.append(f"{label} over its limit at {len(bad)} tau ({', '.join(f'{t:g}' for t in bad[:6])}"
                           f"{', ...' if len(bad) > 6 else ''} s), worst at tau {tau:g} s: {ns(value)} against "
                           f"{ns(limit)}, {ns(value - limit)} over")
        elif tightest is None or (limit - value) / limit < tightest[0]:
            tightest = ((limit - value) / limit, f"{label} closest at tau {tau:g} s: {ns(value)} against {ns(limit)}")
    te = verdict.get("time_error")
    if te:
        if not te["passed"]:
            failing.append(f"max |TE| {ns(te['max_abs_te'])} against {ns(te['limit'], 0)}, "
                           f"{ns(te['max_abs_te'] - te['limit'])} over")
        elif tightest is None or te["margin"] / te["limit"] < tightest[0]:
            tightest = (te["margin"] / te["limit"], f"max |TE| {ns(te['max_abs_te'])} against {ns(te['limit'], 0)}")
    for lim in verdict.get("limits", []):
        name = {"cte": "|cTE|", "max_abs_te_l": "max |TE_L|", "dte_h_pp": "dTE_H p-p"}.get(lim["quantity"], lim["quantity"])
        if not lim["passed"]:
            failing.append(f"{name} {ns(lim['value'])} against {ns(lim['limit'], 0)}, "
                           f"{ns(lim['value'] - lim['limit'])} over")
    split = verdict.get("split")
    tail = ""
    if split and split.get("cte") is not None:
        tail = f" (cTE {split['cte'] * 1e9:+.1f} ns, max |dTE| {ns(split.get('max_abs_dte'))})"
    if failing:
        return "; ".join(failing) + tail
    if verdict.get("passed"):
        return ("every limit met" + (f"; {tightest[1]}" if tightest else "")) + tail
    uncovered = [f"not covered: {n}" for n in verdict.get("not_covered") or []]
    return "; ".join(uncovered + list(verdict.get("not_evaluated") or []) or ["nothing could be evaluated"])


def mask_verdicts(subject: str, verdicts: dict[str, dict]) -> list[Verdict]:
    """One :class:`Verdict` per clock class: ``verdicts`` maps a mask name to ``ClockVerdict.to_dict()``."""
    return [Verdict(f"{subject} against {name}", _given(v), mask_reason(v)) for name, v in verdicts.items()]


def _given(verdict: dict) -> bool | None:
    """True for PASS, False for FAIL, None for a verdict not given (INCOMPLETE, NOT EVALUATED)."""
    word = verdict.get("verdict", "PASS" if verdict.get("passed") else "FAIL")
    return {"PASS": True, "FAIL": False}.get(word)


_STYLE = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1100px; color: #222; }
h1 { font-size: 1.5em; } h2 { font-size: 1.2em; border-bottom: 1px solid #ccc; margin-top: 2em; }
table { border-collapse: collapse; margin: 0.6em 0; } td, th { border: 1px solid #ccc; padding: 0.25em 0.6em; }
th { background: #f3f3f3; text-align: left; } td.num { text-align: right; font-variant-numeric: tabular-nums; }
.verdict .word { font-weight: bold; } .pass .word { color: #13702b; } .fail .word { color: #b3141b; }
.not-given .word { color: #8a6d00; } figure { margin: 1em 0; } figure img { max-width: 100%; }
figcaption { font-size: 0.9em; color: #555; } p.meta { color: #666; font-size: 0.9em; }
"""


def _cell(value) -> str:
    if isinstance(value, float):
        text = "-" if not math.isfinite(value) else f"{value:.4g}"
        return f'<td class="num">{text}</td>'
    if isinstance(value, int) and not isinstance(value, bool):
        return f'<td class="num">{value}</td>'
    return f"<td>{html.escape(str(value))}</td>"


def _image(path: Path, caption: str) -> str:
    data = base64.b64encode(Path(path).read_bytes()).decode("ascii")
    name = html.escape(Path(path).name)
    return (f'<figure><img src="data:image/png;base64,{data}" alt="{name}" data-file="{name}">'
            f"<figcaption>{html.escape(caption or name)}</figcaption></figure>")


def write_html(path: str | Path, title: str, sections: list[Section], *, command: str = "") -> Path:
    """Write the page ``path`` (its folder is created): ``title``, the command that made it, ``sections``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    parts = [f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>',
             f"<style>{_STYLE}</style></head><body>", f"<h1>{html.escape(title)}</h1>",
             f'<p class="meta">chronofuse {html.escape(__version__)}'
             + (f" &middot; <code>{html.escape(command)}</code>" if command else "") + "</p>"]
    for sec in sections:
        parts.append(f"<section><h2>{html.escape(sec.title)}</h2>")
        if sec.verdicts:
            parts.append('<table class="verdicts"><tr><th>what</th><th>verdict</th><th>why</th></tr>')
            for v in sec.verdicts:
                cls = {True: "pass", False: "fail", None: "not-given"}[v.passed]
                parts.append(f'<tr class="verdict {cls}" data-subject="{html.escape(v.subject)}" data-verdict="{v.word}">'
                             f"<td>{html.escape(v.subject)}</td><td class=\"word\">{v.word}</td>"
                             f'<td class="reason">{html.escape(v.reason)}</td></tr>')
            parts.append("</table>")
        if sec.table is not None:
            header, rows = sec.table
            parts.append("<table><tr>" + "".join(f"<th>{html.escape(str(h))}</th>" for h in header) + "</tr>")
            parts += ["<tr>" + "".join(_cell(c) for c in row) + "</tr>" for row in rows]
            parts.append("</table>")
        parts += [f"<p>{html.escape(note)}</p>" for note in sec.notes]
        parts += [_image(p, caption) for p, caption in sec.images]
        parts.append("</section>")
    parts.append("</body></html>\n")
    path.write_text("\n".join(parts), encoding="utf-8")
    return path


# --- the pages of the commands -----------------------------------------------------------------------------


def _images(out: Path, names) -> list[tuple[Path, str]]:
    captions = {
        "time_error.png": "1PPS time error of each receiver after the qErr correction",
        "oscillator_phase.png": "the free-running oscillator's phase",
        "adev.png": "Allan deviation: the oscillator with its theory, and the receivers",
        "mtie.png": "MTIE in ns: the receivers, the disciplined output and the mask",
        "tdev.png": "TDEV in ns: the receivers, the disciplined output and the mask",
        "swarm.png": "the followers' time error to the leader and to true time, the leader's GNSS outage shaded",
        "discipline/time_error.png": "the disciplined output's time error, the controller's states shaded",
        "discipline/adev.png": "ADEV of the free-running oscillator, the GNSS reference and the disciplined output",
        "discipline/holdover.png": "time error accumulated in holdover, the controller against the clairvoyant filter",
        "holdover.png": "time error accumulated in holdover, the controller against the clairvoyant filter",
    }
    return [(out / n, captions.get(n, n)) for n in names if str(n).endswith(".png") and (out / n).exists()]


def _coverage_note(label: str, rx: dict, duration_s: float) -> str | None:
    """Why a receiver's curves end before the grid does, from its own numbers: where each ends, how few terms
    are left there, and the record's missing epochs. None when no curve ends early."""
    missing = rx["pps_error"]["n_missing"] / max(rx["pps_error"]["n"], 1)
    ends, falls = [], []
    for stat, dev in rx["deviations"].items():
        pairs = [(t, v, n) for t, v, n in zip(dev["tau"], dev["dev"], dev["n"])]
        have = [p for p in pairs if p[1] is not None]
        if not have or len(have) == len(pairs):
            continue
        tau, value, n = have[-1]
        ends.append(f"{stat.upper()} ends at tau {tau:g} s, from {n:,} terms there (of {have[0][2]:,} at tau "
                    f"{have[0][0]:g} s); none is left at tau {pairs[len(have)][0]:g} s")
        if len(have) > 1 and value < have[-2][1]:
            falls.append(stat.upper())
    if not ends:
        return None
    note = (f"{label}: {'; '.join(ends)}. {missing:.1%} of its epochs are missing (no fix, rejected outliers, the "
            "outage), and a term is used only where the samples it needs are present: at long tau nearly every term "
            f"spans a gap, so the curves stop well before the run's {duration_s:g} s.")
    if falls:
        note += (f" The last {', '.join(falls)} points fall because the few terms left come from the gap-free "
                 "stretches, the quietest ones: that is a selection of the data, not a better receiver.")
    return note


def _discipline_verdicts(d: dict) -> list[Verdict]:
    out = []
    over = d.get("locked_over_threshold_seconds")
    if over is not None:
        out.append(Verdict("locked only while its criteria hold", over == 0,
                           f"{over:g} s reported locked with |time error| over the lock threshold" if over else
                           "no second reported locked had a time error over the lock threshold"))
    rms, best = d.get("time_error_rms_ns"), d.get("optimal_rms_ns")
    if rms is not None and best:
        out.append(Verdict("time error within 1.1x of the clairvoyant bound", rms <= 1.1 * best,
                           f"{rms:.1f} ns rms against the clairvoyant filter's {best:.1f} ns (x{rms / best:.2f})"))
    out += mask_verdicts("disciplined output", d.get("masks", {}))
    return out


def _discipline_section(d: dict, out: Path, prefix: str) -> Section:
    rows = [[k, d[k]] for k in ("controller", "design", "time_error_rms_ns", "time_error_pp_ns", "optimal_rms_ns",
                                "convergence_s", "holdover_s", "holdover_error_ns", "predicted_holdover_sigma_ns",
                                "dac_rail_alarm_seconds") if k in d]
    rows += [[f"seconds {k}", v] for k, v in d.get("state_seconds", {}).items()]
    notes = []
    if d.get("masks_record"):
        notes.append(f"Masks checked on {d['masks_record']}.")
    files = [f"{prefix}{n}" for n in ("time_error.png", "adev.png", "holdover.png")]
    return Section("Disciplined oscillator: time error with states, holdover, masks", _discipline_verdicts(d),
                   (["quantity", "value"], rows), notes, _images(out, files))


def run_page(summary: dict, out: Path, command: str = "chronofuse run") -> Path:
    """The page of ``chronofuse run``: receivers, masks with reasons, the disciplined output, holdover, swarm."""
    scn = summary["scenario"]
    osc = summary["oscillator"]
    sections = [Section("Scenario", notes=[f"{scn['name']}: {scn.get('description', '')}",
                                           f"oscillator {osc['model']}: free-run phase {osc['free_run']['max_abs_ns']:.1f} ns "
                                           f"max |x| after {scn['duration_s']:g} s"])]
    rows = [[label, rx["pps_error"].get("rms_ns", float("nan")), rx["pps_error"].get("peak_to_peak_ns", float("nan")),
             rx["pps_error"]["n_missing"], f"{rx['fix_fraction']:.1%}", f"{rx['gdop_over_5_fraction']:.1%}"]
            for label, rx in summary["receivers"].items()]
    verdicts = []
    if summary.get("mask"):
        name = summary["mask"]["name"]
        verdicts = [Verdict(f"{label} against {name}", _given(v), mask_reason(v))
                    for label, v in summary["mask"]["receivers"].items()]
    notes = [n for n in (_coverage_note(label, rx, scn["duration_s"]) for label, rx in summary["receivers"].items()) if n]
    sections.append(Section("Receivers", verdicts, (["receiver", "1PPS rms (ns)", "peak-to-peak (ns)", "missing",
                                                     "fix", "GDOP > 5"], rows), notes,
                            _images(out, ["time_error.png", "oscillator_phase.png", "adev.png", "mtie.png", "tdev.png"])))
    d = summary.get("discipline")
    if d and "skipped" in d:
        sections.append(Section("Disciplined oscillator", [Verdict("disciplining", None, d["skipped"])]))
    elif d:
        sections.append(_discipline_section(d, out, "discipline/"))
    w = summary.get("swarm")
    if w:
        outage = w.get("to_leader_in_outage_rms_ns")
        rows = [[i + 1, w["to_leader_rms_ns"][i], w["to_true_rms_ns"][i], "-" if outage is None else outage[i]]
                for i in range(w["followers"])]
        sections.append(Section(f"Swarm ({w['algorithm']}, {w['topology']})", table=(
            ["follower", "to leader rms (ns)", "to true time rms (ns)", "to leader in the outage rms (ns)"], rows),
            notes=[f"leader to true time: {w['leader_to_true_rms_ns']:.1f} ns rms"], images=_images(out, ["swarm.png"])))
    return write_html(out / "report.html", f"chronofuse run: {scn['name']}", sections, command=command)


def gnssdo_page(summary: dict, out: Path, command: str = "chronofuse gnssdo") -> Path:
    """The page of ``chronofuse gnssdo --out``."""
    title = f"chronofuse gnssdo: {summary.get('scenario', '')}, {summary.get('controller', '')}"
    return write_html(out / "report.html", title, [_discipline_section(summary, out, "")], command=command)


def stability_page(doc: dict, plot: Path, command: str = "chronofuse stability") -> Path:
    """The page of ``chronofuse stability --plot P.png``: ``P.html`` beside it."""
    sections = [Section("Record", notes=[f"{doc['file']}: {doc['n']:,} {doc['kind']} points at {doc['rate']:g} Hz, "
                                         f"{doc['gaps']} missing (gap rule: {doc['gap_rule']})", *doc.get("notes", []),
                                         *(f"warning: {w}" for w in doc.get("warnings", []))])]
    sections.append(Section("Masks", mask_verdicts("record", {v["clock"]: v for v in doc.get("masks", [])})))
    time_stats = {"tdev", "mtie", "tierms"}
    for name, dev in doc["deviations"].items():
        scale, unit = (1e9, " (ns)") if name in time_stats else (1.0, "")
        rows = [[t, n, a, None if v is None else v * scale] for t, n, a, v in zip(dev["tau"], dev["n"], dev["alpha"], dev["dev"])]
        rows = [[r[0], r[1], r[2], float("nan") if r[3] is None else r[3]] for r in rows]
        sections.append(Section(name.upper(), table=(["tau (s)", "n", "alpha", f"{name.upper()}{unit}"], rows)))
    sections.append(Section("Figure", images=[(plot, "every statistic with its intervals, the masks and the verdicts")]))
    return write_html(plot.with_suffix(".html"), f"chronofuse stability: {Path(doc['file']).name}", sections,
                      command=command)


def swarm_page(doc: dict, out: Path, command: str = "chronofuse swarm run") -> Path:
    """The page of ``chronofuse swarm run --out``: each algorithm's RMSE against the Bayesian bound."""
    def span(lo, hi) -> str:
        return "not available" if lo is None or hi is None or lo != lo or hi != hi else f"{lo:.3g}-{hi:.3g}"

    rows, verdicts = [], []
    for name, r in doc["rmse_ns"].items():
        ratio = doc["ratio_to_bound"][name]
        lo, hi = doc["ratio_ci"][name]
        scored = doc["trials"] - len(doc.get("unscored_trials", {}).get(name, ()))
        rows.append([name, r, span(*doc["rmse_ci_ns"][name]), ratio, span(lo, hi)])
        if span(lo, hi) == "not available":  # too few trials scored: no interval, so no verdict either
            verdicts.append(Verdict(f"{name} does not beat the bound", None,
                                    f"RMSE / bound {ratio:.3g} over {scored} scored trial(s): too few for an interval, "
                                    "so no verdict"))
            continue
        verdicts.append(Verdict(f"{name} does not beat the bound", bool(lo >= 0.9),
                                f"RMSE / bound {ratio:.3g} (95 % interval {lo:.3g}-{hi:.3g}); below 0.9 would mean a "
                                "bound that does not bound or an error in the run"))
    return write_html(out / "report.html", "chronofuse swarm run", [Section(
        "Algorithms against the Bayesian bound", verdicts,
        (["algorithm", "RMSE (ns)", "95 % interval", "RMSE / bound", "95 % interval"], rows),
        [f"Bayesian bound: {doc['bound_ns']['rms']:.4g} ns RMS over the run, {doc['bound_ns']['final']:.4g} ns at the "
         f"end; {doc['trials']} links, URT {doc['urt_mode']}"])], command=command)


def _detect_verdict(subject: str, doc: dict) -> Verdict:
    """The integrity verdict of one detection document (a file's, or one station's of a clock product)."""
    state = doc["state"]
    if state == "unavailable":
        return Verdict(subject, None, "integrity unavailable: " + "; ".join(doc.get("unavailable_reasons") or ["-"]))
    n = doc.get("n_alarms", 0)
    if not n:
        return Verdict(subject, True, f"no alarm in {doc.get('n_tested', '?')} tested epochs: no window's statistic "
                                      f"crossed the threshold {doc.get('threshold', float('nan')):.4g}")
    first = (doc.get("alarms") or [{}])[0]
    where = f", channel {first['channel']}" if first.get("channel") else ""
    stat = first.get("statistic")
    return Verdict(subject, False, f"{n} alarm(s) in {doc.get('n_tested', '?')} tested epochs; the first at t = "
                                   f"{first.get('t', '?')} with statistic "
                                   f"{'?' if stat is None else format(stat, '.4g')} over the threshold "
                                   f"{doc.get('threshold', float('nan')):.4g}{where}")


def _metres(value) -> str:
    return "-" if value is None or not math.isfinite(value) else f"{value:.1f} m"


def _raim_section(doc: dict, file: str) -> Section:
    """``detect OBS --nav NAV --raim``: the integrity verdict, the protection levels against the alert limits,
    the check against a given position, and every epoch that detected a fault."""
    states = doc["epoch_states"]
    alarms = doc.get("alarms", [])
    excluded = [a for a in alarms if a["state"] == "excluded"]
    if doc["state"] == "alarm":
        first = alarms[0]
        verdict = Verdict("integrity (RAIM)", False,
                          f"{len(alarms)} epoch(s) detected a fault: {len(excluded)} excluded a satellite "
                          f"({', '.join(doc['excluded']) or 'none'}), {len(alarms) - len(excluded)} raised an alarm "
                          f"naming none; the first at t = {first['t']:g} s (test statistic {first['statistic']:.4g})")
    elif doc["state"] == "unavailable":
        verdict = Verdict("integrity (RAIM)", None, "integrity unavailable: "
                          + ("; ".join(doc.get("unavailable_reasons") or []) or "too few epochs could be tested"))
    else:
        verdict = Verdict("integrity (RAIM)", True, f"no fault detected in {doc['n_tested']:,} tested epochs "
                          f"(availability {doc['availability']:.1%}, P_fa {doc['pfa']:g})")
    hpl, vpl = doc["hpl_m"], doc["vpl_m"]
    hal, val = doc["horizontal_alert_limit_m"], doc["vertical_alert_limit_m"]
    levels = Verdict("protection levels within the alert limits", states.get("unavailable", 0) == 0,
                     f"HPL median {_metres(hpl['median'])} (95 % {_metres(hpl['p95'])}) against HAL {hal:g} m, "
                     f"VPL median {_metres(vpl['median'])} (95 % {_metres(vpl['p95'])}) against VAL {val:g} m; "
                     f"{states.get('unavailable', 0):,} of {doc['n_epochs']:,} epochs unavailable")
    verdicts = [verdict, levels]
    check = doc.get("position_check")
    if check is not None:
        lo, hi = check["rate_ci95"]
        verdicts.append(Verdict(
            "the error stays inside the protection levels", check["n_beyond_level"] == 0 or lo <= doc["integrity_risk"],
            f"against the position given: {check['n_beyond_level']} of {check['n_epochs']:,} available epochs beyond a "
            f"level (95 % CI {lo:.2g}..{hi:.2g}; integrity risk {doc['integrity_risk']:g}); horizontal error median "
            f"{check['horizontal_error_m']['median']:.2f} m, max {check['horizontal_error_m']['max']:.2f} m"))
    rows = [[f"{a['t']:g}", a["state"], a["channel"], f"{a['statistic']:.4g}"] for a in alarms[:200]]
    notes = [f"{file}: RAIM ({'+'.join(doc['systems'])}), {doc['n_epochs']:,} epochs: "
             + ", ".join(f"{states[s]:,} {s}" for s in states),
             f"minimum detectable bias median {_metres(doc['mdb_m']['median'])} at P_md {doc['p_md']:g}; "
             f"integrity risk {doc['integrity_risk']:g} per epoch"]
    if len(alarms) > 200:
        notes.append(f"the table shows the first 200 of {len(alarms)} epochs that detected a fault")
    notes += [f"warning: {w}" for w in doc.get("warnings", [])]
    return Section("Position-domain integrity (RAIM)", verdicts,
                   (["t (s)", "state", "satellite", "statistic"], rows) if rows else None, notes)


def detect_page(doc: dict, path: Path, file: str, command: str = "chronofuse detect") -> Path:
    """The page of ``chronofuse detect FILE --report P.html``: the verdict with its reason, every alarm (or,
    for a clock product, one verdict per station; for ``--raim``, the protection levels and every epoch that
    detected a fault)."""
    if doc["mode"] == "raim":
        return write_html(path, f"chronofuse detect (RAIM): {Path(file).name}", [_raim_section(doc, file)],
                          command=command)
    if doc["mode"] == "clock-product":
        verdicts = [_detect_verdict(f"{row['station']}: integrity", row) for row in doc["stations"]]
        sec = Section(f"Clock product: {doc['n_stations']} stations, overall {doc['state']}", verdicts,
                      notes=[f"window {doc['window']}, P_fa {doc['pfa']:g}"])
        return write_html(path, f"chronofuse detect: {Path(file).name}", [sec], command=command)
    rows = [[a.get("t"), a.get("statistic"), a.get("channel") or "-"] for a in doc.get("alarms", [])[:200]]
    notes = [f"{file}: {doc['mode']} mode, {doc.get('n_epochs', '?')} epochs ({doc.get('n_skipped', '?')} skipped), "
             f"window {doc.get('window', '?')}, P_fa {doc.get('pfa', '?')}"]
    if doc.get("untested"):
        notes.append(f"not tested: {', '.join(doc['untested'])}")
    notes += [f"warning: {w}" for w in doc.get("warnings", [])]
    return write_html(path, f"chronofuse detect: {Path(file).name}",
                      [Section("Integrity", [_detect_verdict("integrity", doc)],
                               (["t (s)", "statistic", "channel"], rows) if rows else None, notes)], command=command)


def monitor_page(doc: dict, out: Path, command: str = "") -> Path:
    """The page of a monitor session's report (the log DB ``doc["db"]``): each receiver's verdict and plots;
    ``command`` the command line that made it, shown on the page."""
    sections = []
    for rx in doc["receivers"]:
        name = rx["receiver"]
        alarms = rx.get("alarms", 0)
        verdict = Verdict(f"{name}: no alarm", alarms == 0,
                          f"{alarms} alarm(s) in {rx.get('epochs', '?')} epochs ({rx.get('usable', '?')} usable), "
                          f"{rx.get('jumps', 0)} jump(s), {len(rx.get('outages', []))} outage(s)")
        images = [(Path(f), Path(f).stem.replace("_", " ")) for f in doc["files"] if Path(f).name.startswith(f"{name}_")]
        notes = [] if rx.get("clock_bias_epochs") else ["no plot: the log holds no clock bias for this receiver "
                                                        "(its messages carry none, e.g. NMEA, or none was usable)"]
        sections.append(Section(name, [verdict], notes=notes, images=images))
    return write_html(out / "report.html", f"chronofuse monitor: {Path(doc['db']).name}", sections, command=command)
