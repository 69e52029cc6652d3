"""Where and with what a benchmark's numbers were measured."""

from __future__ import annotations

import datetime
import json
import os
import platform
from importlib import metadata
from pathlib import Path

import numpy as np

import rodsim
from rodsim.io.provenance import git_commit

__all__ = ["machine", "write_report"]


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def machine() -> dict[str, str]:
    """Platform, CPU, cores, library versions, date and git commit (all strings, so the
    dict can go into netCDF attributes as ``machine_<key>``)."""
    affinity = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None
    return {
        "platform": platform.platform(),
        "cpu": _cpu_model(),
        "cores": str(os.cpu_count()),
        "cores_available": str(affinity),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "scipy": metadata.version("scipy"),
        "scikit_sundae": metadata.version("scikit-sundae"),
        "rodsim": rodsim.__version__,
        "date": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "git_commit": git_commit() or "unknown",
        "OMP_NUM_THREADS": os.environ.get("OMP_NUM_THREADS", "unset"),
        "OPENBLAS_NUM_THREADS": os.environ.get("OPENBLAS_NUM_THREADS", "unset"),
    }


def write_report(report: dict, markdown: str, stem: Path) -> list[Path]:
    """Write a benchmark's numbers as ``<stem>.json`` (``report``; numpy scalars as floats)
    and its table as ``<stem>.md`` (``markdown``); returns the two paths."""
    json_path, md_path = stem.with_suffix(".json"), stem.with_suffix(".md")
    json_path.write_text(json.dumps(report, indent=1, default=float))
    md_path.write_text(markdown)
    return [json_path, md_path]
