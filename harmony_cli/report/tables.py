"""Table 1 in the paper's layout (Markdown, CSV, LaTeX) and Fig. 4, from run directories only."""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd

from harmony_cli.provenance import Made, record
from harmony_cli.report.metrics import baseline_peak
from harmony_cli.report.plots import plot_comparison
from harmony_cli.report.text import fmt

# The paper's Table 1 (KNITRO, Intel i9 3.6 GHz): (transcription, K) -> (mean solve ms, max tracking error cm)
PAPER = {
    ("traditional", 6): (11, 19.4),
    ("traditional", 26): (58, 9.8),
    ("bezier", 6): (9, 7.8),
    ("bezier", 26): (12, 5.4),
}
ORDER = {"traditional": 0, "bezier": 1}


def load_runs(dirs: list[Path]) -> list[dict]:
    runs = []
    for d in dirs:
        summary = json.loads((d / "summary.json").read_text()) if (d / "summary.json").exists() else {}
        meta = json.loads((d / "meta.json").read_text()) if (d / "meta.json").exists() else {}
        runs.append({"dir": d, "summary": summary, "meta": meta})
    key = lambda r: (
        r["summary"].get("solver", ""),
        ORDER.get(r["summary"].get("transcription"), 9),
        r["summary"].get("knots", 0),
    )
    return sorted(runs, key=key)


def _column(s: dict) -> str:
    name = "Bezier" if s.get("transcription") == "bezier" else "Traditional"
    return f"{name} K={s.get('knots')} ({s.get('solver')})"


def _ours(s: dict) -> dict[str, str]:
    """Everything the run measured; a run that failed part-way still shows what it built and measured."""
    rows: dict[str, str] = {}
    if "decision_variables" in s:
        bezier = s["transcription"] == "bezier"
        n_dof = s["n_dof"]
        formula = (
            f"N x n_dof = {s['control_points']} x {n_dof}" if bezier else f"2K x n_dof = 2 x {s['knots']} x {n_dof}"
        )
        extra = s["decision_variables"] - (s["control_points"] if bezier else 2 * s["knots"]) * n_dof
        formula += f" + {extra} compliant offsets" if extra else ""
        rows |= {
            "Long horizon": f"{s['horizon_s']:g} s",
            "Time knots": f"K = {s['knots']}",
            "Control point No.": f"N = {s['control_points']}" if bezier else "-",
            "Decision variable": s["decision_label"],
            "Decision variable No.": f"{formula} = {s['decision_variables']}",
        }
    if "solve_time_ms" in s:
        t, e = s["solve_time_ms"], s["tracking_error"]
        rows |= {
            "Average computation time": f"{t['mean']:.1f} ms",
            "Median solve time": f"{t['median']:.1f} ms",
            "p95 solve time": f"{t['p95']:.1f} ms",
            "Max solve time": f"{t['max']:.1f} ms",
            "Max tracking error": f"{100 * e['max_m']:.2f} cm",
            "RMS tracking error": f"{100 * e['rms_m']:.2f} cm",
            "Failed solves": f"{s['failed_solves']} / {s['steps']}",
        }
    rows |= _disturbance(s.get("task", s))
    status = s.get("status", "missing")
    rows["Status"] = status if status == "completed" else f"{status}: {s.get('error', '')}"
    return rows


def _disturbance(task: dict) -> dict[str, str]:
    """Task success and clearance, squeeze-force tracking and push responses, when the run measured them."""
    rows = {}
    if "success" in task:
        rows["Task success"] = "yes" if task["success"] else "no"
    clearance = [v for c in task.get("min_clearance_m", {}).values() for v in c.values()]
    if clearance:
        rows["Min clearance to obstacles"] = f"{min(clearance):.3f} m"
    if (force := task.get("force")) and force["rms_N"] is not None:  # a reference > 0 at some step
        rows["Squeeze-force error RMS / max (ref > 0)"] = f"{force['rms_N']:.2f} / {force['max_N']:.2f} N"
        for phase, hands in force["phases"].items():
            rms, top = max(v["rms_N"] for v in hands.values()), max(v["max_N"] for v in hands.values())
            rows[f"Squeeze-force error RMS / max ({phase})"] = f"{rms:.2f} / {top:.2f} N"
    for name, p in task.get("pushes", {}).items():
        rows |= {
            f"Push {name}: peak displacement (baseline)": f"{fmt(p['peak_displacement_m'], 'cm', 100, digits=3)} "
            f"({fmt(baseline_peak(p, 'peak_displacement_m'), 'cm', 100, digits=3)})",
            f"Push {name}: peak pad force (baseline)": f"{fmt(p['peak_pad_force_N'], 'N')} "
            f"({fmt(baseline_peak(p, 'peak_pad_force_N'), 'N')})",
            f"Push {name}: recovery to 1 cm": fmt(p["recovery_s"], "s", missing="never"),
            f"Push {name}: peak pusher force": fmt(p.get("peak_push_N"), "N"),
            f"Push {name}: pusher impulse": fmt(p.get("applied_impulse_N_s"), "N s"),
        }
        if p.get("peak_contact_N") is not None:
            rows[f"Push {name}: peak pad-box contact force (baseline)"] = (
                f"{fmt(p['peak_contact_N'], 'N')} ({fmt(baseline_peak(p, 'peak_contact_N'), 'N')})"
            )
    return rows


def _paper(s: dict) -> dict[str, str] | None:
    values = PAPER.get((str(s.get("transcription")), int(s.get("knots") or 0)))
    if values is None or s.get("horizon_s") != 5.0:
        return None
    bezier = s["transcription"] == "bezier"
    n = 6 * 18 if bezier else 2 * s["knots"] * 18
    return {
        "Long horizon": "5 s",
        "Time knots": f"K = {s['knots']}",
        "Control point No.": "N = 6" if bezier else "-",
        "Decision variable No.": str(n),
        "Average computation time": f"{values[0]} ms",
        "Max tracking error": f"{values[1]} cm",
        "Status": "KNITRO, i9 3.6 GHz",
    }


def labels(runs: list[dict]) -> list[str]:
    """One column label per run: transcription, K and solver, plus the run directory (the grid point) when
    several runs share them (e.g. a grid over admittance.enabled)."""
    plain = [_column(r["summary"]) for r in runs]
    return [f"{p} [{r['dir'].name}]" if plain.count(p) > 1 else p for p, r in zip(plain, runs)]


def table(runs: list[dict], with_paper: bool = True) -> pd.DataFrame:
    columns = {}
    for r, label in zip(runs, labels(runs)):
        s = r["summary"]
        columns[f"{label} ours"] = _ours(s)
        paper = _paper(s) if with_paper else None
        if paper:
            columns[f"{_column(s).split(' (')[0]} paper"] = paper
    frame = pd.DataFrame(columns).fillna("")
    return frame.rename_axis("Items")


def _latex(frame: pd.DataFrame) -> str:
    esc = lambda v: str(v).replace("_", r"\_").replace("%", r"\%").replace("&", r"\&")
    lines = [
        r"\begin{tabular}{l" + "c" * frame.shape[1] + "}",
        r"\hline",
        " & ".join(["Items"] + [esc(c) for c in frame.columns]) + r" \\",
        r"\hline",
    ]
    lines += [" & ".join([esc(i)] + [esc(v) for v in row]) + r" \\" for i, row in frame.iterrows()]
    return "\n".join(lines + [r"\hline", r"\end{tabular}", ""])


def write_table(runs: list[dict], out: Path, name: str, title: str, with_paper: bool = True) -> list[Path]:
    frame = table(runs, with_paper)
    concurrency = sorted({r["meta"].get("concurrency", 1) for r in runs})
    cpu = sorted({r["meta"].get("cpu", "?") for r in runs})
    note = (
        f"Measured by harmony on {', '.join(cpu)}, {'/'.join(map(str, concurrency))} run(s) at a time; "
        f"solve time is the wall time of the whole-body MPC solver call per control step."
    )
    header = "| Items | " + " | ".join(frame.columns) + " |\n|" + "---|" * (frame.shape[1] + 1) + "\n"
    body = "".join("| " + " | ".join([str(i)] + [str(v) for v in row]) + " |\n" for i, row in frame.iterrows())
    paths = [out / f"{name}.md", out / f"{name}.csv", out / f"{name}.tex"]
    paths[0].write_text(f"# {title}\n\n{header}{body}\n{note}\n")
    frame.to_csv(paths[1])
    paths[2].write_text(f"% {title}. {note}\n" + _latex(frame))
    return paths


def compare_report(
    dirs: list[Path], out: Path, name: str = "table", main_solver: str | None = None, grid_keys: list[str] | None = None
) -> list[Path]:
    """Table for the main solver (paper layout; the paper's values beside ours when the grid varies the
    transcription or K, or is not given), an extended table with every run, Fig. 4."""
    out.mkdir(parents=True, exist_ok=True)
    runs = load_runs(dirs)
    solvers = [r["summary"].get("solver") for r in runs]
    main_solver = main_solver or (solvers[0] if solvers else None)
    main = [r for r in runs if r["summary"].get("solver") == main_solver]
    paper = grid_keys is None or bool({"mpc.transcription", "mpc.knots"} & set(grid_keys))
    title = "Whole-body MPC: traditional vs Bezier" if paper else f"Ablation over {', '.join(grid_keys or [])}"
    paths = write_table(main, out, name, f"{title} ({main_solver})", paper)
    if len(set(solvers)) > 1:
        paths += write_table(runs, out, f"{name}_extended", f"{title}: every solver mode", paper)
    steps = {
        label: pd.read_csv(r["dir"] / "steps.csv")
        for r, label in zip(main, labels(main))
        if r["summary"].get("status") == "completed"
    }
    if steps:
        hands = [c.removesuffix("_error_m") for c in next(iter(steps.values())).columns if c.endswith("_error_m")]
        paths += plot_comparison(out, steps, hands)
    record(paths, Made.from_metas(r["meta"] for r in runs))
    return paths
