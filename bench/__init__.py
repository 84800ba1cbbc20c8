"""The benchmarks behind the figures the documentation quotes: each is ``python -m bench.NAME`` and writes its
own measurement page, ``docs/measurements/NAME.md`` (see ``bench.measurements``). Nothing in the tests or the
package imports them. Beside them, ``bench.compatibility`` writes the compatibility page from the rows the
importer tests record; the tests import it for the rows' format (it needs only jinja2)."""
