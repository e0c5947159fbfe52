"""Force figures: squeeze-force tracking per hand over the task's phases, and each push's response."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import pandas as pd

from harmony_cli.report.figure import plt, save
from harmony_cli.report.metrics import AFTER_PUSH_S

if TYPE_CHECKING:
    from collections.abc import Sequence

    from harmony_cli.scenario.world import PushSpec


def _shade_phases(ax, steps: pd.DataFrame) -> None:
    """Alternate grey bands, one per task phase, labelled at the top."""
    if "phase" not in steps:
        return
    t, phase = steps["t"].to_numpy(), steps["phase"].to_numpy()
    starts = [0] + [i for i in range(1, len(phase)) if phase[i] != phase[i - 1]]
    dt = t[1] - t[0] if len(t) > 1 else 0.0
    for n, i in enumerate(starts):
        end = t[starts[n + 1]] if n + 1 < len(starts) else t[-1] + dt
        if n % 2:
            ax.axvspan(t[i], end, color="0.9", lw=0)
        ax.text(
            (t[i] + end) / 2,
            1.0,
            phase[i],
            transform=ax.get_xaxis_transform(),
            ha="center",
            va="bottom",
            fontsize=7,
            rotation=30,
        )


def _shade_push(ax, push: PushSpec, label: bool = True) -> None:
    ax.axvspan(
        push.start,
        push.start + push.duration,
        color="tab:red",
        alpha=0.15,
        lw=0,
        label=f"push {push.name}" if label else None,
    )


def plot_forces(out: Path, steps: pd.DataFrame, hands: list[str], pushes: Sequence[PushSpec] = ()) -> Path:
    """force_tracking.png: per hand, the sensed pad normal force (and the simulator's pad-box contact force) against
    the squeeze-force reference when logged; task phases shaded and labelled, pushes in red."""
    fig, axes = plt.subplots(len(hands), 1, figsize=(9, 2.6 * len(hands)), sharex=True, squeeze=False)
    for ax, hand in zip(axes[:, 0], hands):
        _shade_phases(ax, steps)
        for n, push in enumerate(pushes):
            _shade_push(ax, push, label=n == 0 or len(pushes) > 1)
        if f"{hand}_force_ref_N" in steps:
            ax.plot(steps["t"], steps[f"{hand}_force_ref_N"], "k--", lw=1, label="reference")
        ax.plot(steps["t"], steps[f"{hand}_force_normal_N"], lw=1, label="measured (wrist sensor)")
        if f"{hand}_contact_N" in steps:
            ax.plot(steps["t"], steps[f"{hand}_contact_N"], lw=0.6, alpha=0.6, label="pad-box contact (simulator)")
        ax.set(ylabel=f"{hand} normal force [N]")
        ax.legend(fontsize=7, loc="upper left")
    axes[-1, 0].set(xlabel="time [s]")
    fig.suptitle("Squeeze force: reference vs measured (pad pressed > 0)")
    path = out / "force_tracking.png"
    save(fig, path)
    return path


def plot_push(
    out: Path,
    steps: pd.DataFrame,
    hands: list[str],
    push,
    pushed_hand: str | None,
    before: float = 1.0,
    after: float = AFTER_PUSH_S,
) -> Path:
    """push_<name>.png: hand displacement (from the push-free run when logged, and from the live reference) and
    pad normal forces (sensed, reference, the simulator's contact) around one push."""
    end = push.start + push.duration
    part = steps[(steps["t"] >= push.start - before) & (steps["t"] <= end + after)]
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 5), sharex=True)
    for ax in (top, bottom):
        _shade_push(ax, push)
    for hand in hands:
        name = hand + (" (pushed)" if hand == pushed_hand else "")
        (line,) = top.plot(part["t"], 100 * part[f"{hand}_error_m"], lw=0.8, ls=":", label=f"{name} from reference")
        if f"{hand}_push_displacement_m" in part:
            top.plot(
                part["t"],
                100 * part[f"{hand}_push_displacement_m"],
                color=line.get_color(),
                lw=2 if hand == pushed_hand else 1,
                label=f"{name} from push-free run",
            )
        (line,) = bottom.plot(part["t"], part[f"{hand}_force_normal_N"], lw=1, label=f"{hand} measured")
        if f"{hand}_force_ref_N" in part:
            bottom.plot(
                part["t"], part[f"{hand}_force_ref_N"], "--", color=line.get_color(), lw=1, label=f"{hand} reference"
            )
        if f"{hand}_contact_N" in part:
            bottom.plot(
                part["t"], part[f"{hand}_contact_N"], ":", color=line.get_color(), lw=1, label=f"{hand} pad-box contact"
            )
    if f"push_{push.name}_N" in part:
        bottom.plot(part["t"], part[f"push_{push.name}_N"], color="k", lw=1.5, label=f"pusher ({push.name})")
    top.axhline(1.0, color="k", ls="--", lw=0.6, label="1 cm")
    kind = (
        f"{list(push.force)} N"
        if push.stiffness is None
        else f"spring {push.stiffness:g} N/m, max {math.hypot(*push.force):g} N"
    )
    top.set(
        ylabel="hand displacement [cm]",
        title=f"push {push.name}: {kind} on {push.body}{'/' + push.link if push.link else ''} for {push.duration:g} s",
    )
    bottom.set(xlabel="time [s]", ylabel="force [N]")
    top.legend(fontsize=7)
    bottom.legend(fontsize=7)
    path = out / f"push_{push.name}.png"
    save(fig, path)
    return path
