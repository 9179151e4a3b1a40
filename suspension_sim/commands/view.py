"""``suspension-sim view RUN_DIR``: replay a finished run in the browser.

By default the run's ``viewer.html`` (written now if the run folder has none) is served on 127.0.0.1 and its URL
printed (and opened in a browser when one is available); ``--live`` instead streams the run into a meshcat
server at ``--rate`` times real time.  ``--write-only`` just writes ``viewer.html`` and exits.
"""
from __future__ import annotations

from pathlib import Path

import typer


def register(app: typer.Typer) -> None:
    @app.command()
    def view(
        run_dir: Path = typer.Argument(..., help="run folder (with timeseries.parquet and summary.json)"),
        live: bool = typer.Option(False, "--live", help="stream into a live meshcat server instead of serving viewer.html"),
        rate: float = typer.Option(1.0, "--rate", help="with --live: simulated seconds per wall second"),
        camera: str = typer.Option("three_quarter", "--camera", help="camera preset: three_quarter|side|front|rear|top|wheel"),
        port: int = typer.Option(0, "--port", help="port for serving viewer.html (0 = any free port)"),
        no_browser: bool = typer.Option(False, "--no-browser", help="only print the URL"),
        write_only: bool = typer.Option(False, "--write-only", help="write viewer.html (if missing) and exit"),
        rebuild: bool = typer.Option(False, "--rebuild", help="rewrite viewer.html even if it exists"),
    ):
        """Replay a finished run in the 3D browser viewer."""
        from ..cli import console, fail, guarded
        from ..viewer import CAMERAS

        if camera not in CAMERAS:
            fail(f"--camera: unknown preset {camera!r} (choose from {', '.join(CAMERAS)})")

        def go():
            from ..report import load_run

            result = load_run(run_dir)
            if live:
                from ..viewer import replay_live

                v = replay_live(result, rate=rate, camera=camera, console=console)
                console.print("replay finished; the viewer stays up until Ctrl-C")
                _wait()
                v.server.close()
                return
            vpath = run_dir / "viewer.html"
            if rebuild or not vpath.exists():
                from ..viewer import write_viewer

                write_viewer(result, vpath, camera=camera)
                console.print(f"wrote [bold]{vpath}[/]")
            if write_only:
                return
            serve(run_dir, "viewer.html" + (f"#camera={camera}" if camera != "three_quarter" else ""), port,
                  not no_browser, console)

        guarded(go)


def _wait():
    import time

    try:
        while True:
            time.sleep(1)
    except KeyboardInterrupt:
        pass


def serve(folder: Path, page: str, port: int, open_browser: bool, console) -> None:
    """Serve ``folder`` on 127.0.0.1 until Ctrl-C, printing the page's URL."""
    import functools
    import http.server
    import threading

    class Quiet(http.server.SimpleHTTPRequestHandler):
        def log_message(self, *args):
            pass

    handler = functools.partial(Quiet, directory=str(folder))
    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", port), handler)
    url = f"http://127.0.0.1:{httpd.server_address[1]}/{page}"
    console.print(f"viewer: [bold]{url}[/] (Ctrl-C to stop; the file also opens directly: {folder / page.split('#')[0]})")
    t = threading.Thread(target=httpd.serve_forever, daemon=True)
    t.start()
    if open_browser:
        import webbrowser

        try:
            webbrowser.open(url, new=2)
        except Exception:
            pass
    _wait()
    httpd.shutdown()
