"""The study's command line as the tests call it: in this process, its exit code returned rather than raised."""

from __future__ import annotations

from orchestrator import run as cli


def main(*argv):
    """``orchestrator/run.py`` with ``argv`` (any values, given as text), its exit code."""
    try:
        return cli.main([str(a) for a in argv])
    except SystemExit as exc:
        return exc.code


def one_line(capfd) -> str:
    """The one line a refusal printed (the build's progress lines aside), with no traceback."""
    err = capfd.readouterr().err
    lines = [line for line in err.splitlines() if line.strip() and not line.startswith(("building", "rebuilding"))]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]
