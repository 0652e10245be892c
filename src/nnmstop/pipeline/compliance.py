"""The IOOS compliance checker (CF-1.10 and ACDD-1.3) on the pipeline's datasets.

:func:`checker_findings` runs ``compliance-checker`` on one NetCDF file and returns its
findings, less the documented exclusions (:data:`EXCLUSIONS`, README "Metadata"), which
do not apply to these data:

* ACDD's ``standard_name`` on a variable: CF defines no standard name for the
  quantities of a nondimensional oscillator (energy, impacts per period, Floquet
  multipliers, ...); inventing one would break CF.
* ACDD's geospatial (``geospatial_*``) and time-coverage (``time_coverage_*``)
  attributes: the data have no position on Earth and no calendar time.

Command line: ``python -m nnmstop.pipeline.compliance results/**/*.nc`` prints every remaining
finding and exits with status 1 if there is one.
"""

from __future__ import annotations

import json
import re
import sys
import tempfile
from pathlib import Path

__all__ = ["CHECKERS", "EXCLUSIONS", "checker_findings", "main"]

CHECKERS = ("cf:1.10", "acdd:1.3")
# (checker, pattern on "<check name>: <message>") of the findings that do not apply; see the module docstring.
EXCLUSIONS = (
    ("acdd:1.3", re.compile(r'^variable "[^"]+" missing the following attributes: standard_name$')),
    ("acdd:1.3", re.compile(r"^Global Attributes: (geospatial_\w+|time_coverage_\w+) not present$")),
    ("acdd:1.3", re.compile(r"^geospatial_(lat|lon)_extents_match: geospatial_(lat|lon)_min/max attribute not found")),
)


def _excluded(checker: str, finding: str) -> bool:
    return any(checker == name and pattern.search(finding) for name, pattern in EXCLUSIONS)


def checker_findings(path, checkers=CHECKERS, exclude: bool = True) -> list[str]:
    """Findings of the IOOS compliance checker on the NetCDF file ``path``.

    Parameters
    ----------
    path
        A NetCDF file.
    checkers
        Checker names and versions as ``compliance-checker --test`` takes them.
    exclude
        Leave out the documented exclusions (:data:`EXCLUSIONS`).

    Returns
    -------
    list of str
        ``"<checker> <check name>: <message>"`` for every failed check (all priorities);
        empty when the file passes.
    """
    from compliance_checker.runner import CheckSuite, ComplianceChecker

    path = Path(path)
    if not path.is_file():
        raise ValueError(f"no such dataset: {path}")
    CheckSuite.load_all_available_checkers()
    with tempfile.TemporaryDirectory(prefix="nnmstop-cc-") as tmp:
        report_path = Path(tmp) / "report.json"
        ComplianceChecker.run_checker(
            str(path), list(checkers), 0, "normal", output_filename=str(report_path), output_format="json"
        )
        report = json.loads(report_path.read_text())
    findings = []
    for checker in checkers:
        if checker not in report:
            raise ValueError(f"the compliance checker has no checker {checker!r}")
        for priority in ("high_priorities", "medium_priorities", "low_priorities"):
            for result in report[checker][priority]:
                scored, possible = result["value"]
                if scored >= possible:
                    continue
                for message in result["msgs"] or ["(no message)"]:
                    finding = f"{result['name'].rstrip(':')}: {message}"
                    if not (exclude and _excluded(checker, finding)):
                        findings.append(f"{checker} {finding}")
    return findings


def main(argv=None) -> int:
    """Print the findings of every file named on the command line; status 1 if any."""
    paths = sys.argv[1:] if argv is None else argv
    if not paths:
        print("usage: python -m nnmstop.pipeline.compliance DATASET.nc [...]", file=sys.stderr)
        return 2
    failed = 0
    for path in paths:
        findings = checker_findings(path)
        failed += bool(findings)
        print(f"{path}: {'passes' if not findings else f'{len(findings)} finding(s)'}")
        for finding in findings:
            print(f"  {finding}")
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())


def one_file_per_kind(paths) -> list:
    """The first of ``paths`` (NetCDF files) of each dataset kind (global attribute ``dataset_kind``).

    The checkers' findings follow from a file's layout and metadata, which the variable catalogue fixes per
    kind; checking one file of each kind covers them at a fraction of the checker's cost (seconds per file).
    A file without the attribute is its own kind.
    """
    import netCDF4

    chosen = {}
    for path in sorted(paths):
        with netCDF4.Dataset(path) as ds:
            kind = getattr(ds, "dataset_kind", str(path))
        chosen.setdefault(kind, path)
    return list(chosen.values())
