"""The size of explore.html, the interactive page every run writes, and of what it is made of.

    python -m bench.explore_page            # the default study (about a minute on two cores)
    python -m bench.explore_page --quick    # a budget of 30 designs per run

Why: the page is one self-contained file (plotly.js inlined, the evaluations as JSON) so that it opens from a
file system with no network; its size is what a results folder sent to a colleague carries for it. The study
runs through the command line into a temporary folder; the page is weighed there, with its two parts: plotly.js
(the same for every study) and the study's data (growing with the evaluations).
"""

from __future__ import annotations

import csv
import re
import shutil
import tempfile
from pathlib import Path

from .measurements import Page, Run, Table, write_page


def main(argv=None) -> int:
    run = Run.start(__file__, argv)
    parser = run.parser(__doc__, quick="a budget of 30 designs per run instead of the default study's")
    args = parser.parse_args(argv)
    from orchestrator import run as cli
    from orchestrator.report.explore import plotly_js

    folder = Path(tempfile.mkdtemp(prefix="explore_page_"))
    try:
        rows = []
        studies = {
            "the default study": [],
            "two objectives (sampled, max_compression)": ["--objective", "sampled,max_compression"],
        }
        for label, options in studies.items():
            out = folder / str(len(rows))
            argv_run = ["--out", str(out), "--no-progress", *options] + (["--budget", "30"] if args.quick else [])
            if cli.main(argv_run) != 0:
                raise SystemExit(f"the study {label} did not finish")
            text = (out / "explore.html").read_text(encoding="utf-8")
            data = re.search(r'<script type="application/json" id="study-data">(.*?)</script>', text, re.S).group(1)
            with (out / "evaluations.csv").open() as handle:
                evaluations = sum(1 for _ in csv.DictReader(handle))
            front = out / "front"
            front_files = sum(f.stat().st_size for f in front.glob("*.ssp")) if front.is_dir() else 0
            rows.append(
                (
                    label,
                    f"{len(text.encode()) / 1e6:.2f}",
                    f"{len(plotly_js().encode()) / 1e6:.2f}",
                    f"{len(data.encode()) / 1e6:.2f}",
                    evaluations,
                    f"{front_files / 1e6:.2f}",
                )
            )
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    import plotly

    page = Page(
        name=run.name,
        title="The size of explore.html",
        headline=(
            f"explore.html of the default study: {rows[0][1]} MB, of which plotly.js {rows[0][2]} MB and the "
            f"study's data {rows[0][3]} MB ({rows[0][4]} evaluations)"
        ),
        summary=(
            f"explore.html as `python orchestrator/run.py{' --budget 30' if args.quick else ''}` writes it "
            f"(and with `--objective sampled,max_compression`), with plotly.js {plotly.__version__} inlined; "
            "the design files of the front's points (front/) are beside it, not in it."
        ),
        tables=(
            Table(
                (
                    "study",
                    "explore.html (MB)",
                    "plotly.js (MB)",
                    "data (MB)",
                    "evaluations in evaluations.csv",
                    "front/ design files (MB)",
                ),
                tuple(rows),
            ),
        ),
    )
    write_page(run, page)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
