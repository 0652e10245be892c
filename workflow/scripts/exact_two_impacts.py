"""Snakemake script of rule ``exact_two_impacts``; also runnable standalone.

Under Snakemake it reads ``snakemake.params`` / ``snakemake.output`` / ``snakemake.log``.
Standalone (for debugging)::

    python workflow/scripts/exact_two_impacts.py [--config config/config.yaml]
        [--output results/exact/nnm1_two_impacts.nc] [--log -]

(Snakemake prepends its own preamble to this file, so no ``from __future__`` import here.)
"""

import argparse
import logging
import sys


def _configure_logging(log_path: str | None) -> None:
    handlers = [logging.StreamHandler(sys.stderr)]
    if log_path and log_path != "-":
        handlers = [logging.FileHandler(log_path, mode="w")]
    logging.basicConfig(level=logging.INFO, handlers=handlers, force=True,
                        format="%(asctime)s %(levelname)s %(name)s: %(message)s")


def main(config: dict, output: str, log_path: str | None) -> None:
    from nnmstop.exact import build_two_impact_dataset

    _configure_logging(log_path)
    try:
        build_two_impact_dataset(config, output)
    except Exception:
        logging.getLogger("exact_two_impacts").exception("computing the two-impact family failed")
        raise


if "snakemake" in globals():
    snakemake = globals()["snakemake"]
    main({"model": dict(snakemake.params.model), "exact": dict(snakemake.params.exact)},
         snakemake.output.dataset, snakemake.log[0] if snakemake.log else None)
elif __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", default="config/config.yaml")
    parser.add_argument("--output", default="results/exact/nnm1_two_impacts.nc")
    parser.add_argument("--log", default="-", help="log file, '-' for stderr")
    args = parser.parse_args()
    from nnmstop.config import load_config

    main(load_config(args.config), args.output, args.log)
