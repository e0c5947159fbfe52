"""`harmony view RUN_DIR [RUN_DIR ...]`: replay runs of one scene in the browser, or export / render them."""

from __future__ import annotations

import platform
import threading
import webbrowser
from pathlib import Path

import typer

from harmony_cli.console import fail, literal
from harmony_cli.scenario.models import installed_engines
from harmony_cli.sim.video import VIDEO_SUFFIXES


def view(
    runs: list[Path] = typer.Argument(..., help="Run directories of one scene (the first's timeline drives all)"),
    port: int = typer.Option(8080, help="Port to serve on (the next free one if taken)"),
    host: str = typer.Option("127.0.0.1", help="Address to serve on (0.0.0.0: reachable from other machines)"),
    browser: bool = typer.Option(True, "--browser/--no-browser", help="Open the page in this machine's browser"),
    export: Path | None = typer.Option(None, help="Write a self-contained .html replay here and exit"),
    video: Path | None = typer.Option(None, help="Render the (first) run to this .mp4 or .gif and exit"),
):
    """Replay runs in a local web page (robot, scene, paths, plans, knots, forces, timeline); Ctrl-C ends it."""
    try:  # the page's own imports (viser, yourdfpy) too: a missing extra is one line, not a traceback
        from harmony_cli.view.replay import Replay
        from harmony_cli.view.run_data import NotARun, load_runs
    except ImportError as exc:  # the `view` extra is not installed
        fail(f"view: {exc.name or exc} is missing; install harmony with its `view` extra (pip install -e '.[view]')")
        return
    if export is not None and export.suffix.lower() != ".html":
        fail(f"view --export: {str(export)!r} must end in .html")
    if video is not None and video.suffix.lower() not in VIDEO_SUFFIXES:
        fail(f"view --video: {str(video)!r} must end in one of {', '.join(VIDEO_SUFFIXES)}")
    try:
        loaded = load_runs(runs)
    except NotARun as exc:
        fail(str(exc))
        return
    engine = loaded[0].scenario.sim.engine
    if video is not None and engine not in installed_engines():  # a run is drawn in the engine it ran in
        fail(
            f"view --video: {runs[0]} ran in {engine}, which this Python ({platform.python_version()}) does not have; "
            "`harmony run --video` records a video in either engine"
        )
    if video is not None:
        from harmony_cli.view.video import render_video

        typer.echo(literal(str(render_video(loaded[0], video))))
        if export is None:
            return
    replay = Replay(loaded, port=port, host=host)
    if export is not None:
        typer.echo(literal(str(replay.export(export))))
        replay.close()
        return
    typer.echo(f"replaying {len(loaded)} run(s) at {replay.url} (Ctrl-C to stop)")
    if browser:
        webbrowser.open(replay.url)
    stop = threading.Event()
    try:
        replay.play(stop)
    except KeyboardInterrupt:
        stop.set()
    finally:
        replay.close()
