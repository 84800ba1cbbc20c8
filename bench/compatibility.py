"""The compatibility page: docs/compatibility.md, written from the rows the importer tests record; never by hand.

    python -m bench.compatibility            # writes docs/compatibility.md from tests/compatibility_results/
    python -m bench.compatibility --check    # exits 1 when the page differs from what the rows make

The rows' format and the page's rendering are ``builder.compatibility`` (the tests write rows through it too,
with ``python -m pytest --record-compatibility ...``); a row from elsewhere (fmusim under Wine or qemu-user) is
written with its ``write_row``.
"""

from __future__ import annotations

import argparse
import sys

from builder.compatibility import PAGE, RESULTS, ROOT, RowError, load_rows, render


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.compatibility", description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--check",
        action="store_true",
        help="write nothing; exit 1 when docs/compatibility.md differs from what the rows make",
    )
    args = parser.parse_args(argv)
    try:
        page = render(load_rows())
    except RowError as exc:
        print(f"{parser.prog}: error: {exc}", file=sys.stderr)
        return 2
    if args.check:
        if not PAGE.is_file() or PAGE.read_text(encoding="utf-8") != page:
            print(
                f"{PAGE.relative_to(ROOT)} differs from the rows in {RESULTS.relative_to(ROOT)}: run {parser.prog}",
                file=sys.stderr,
            )
            return 1
        return 0
    PAGE.write_text(page, encoding="utf-8")
    print(f"wrote {PAGE.relative_to(ROOT)}")
    return 0


__all__ = ["main"]

if __name__ == "__main__":
    sys.exit(main())
