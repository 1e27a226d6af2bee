"""The installed Lantern's version, for `lantern --version` and the comparison report."""
from __future__ import annotations


def installed_version() -> str:
    """The version pip installed ('unknown' when run from a copy that was not)."""
    from importlib.metadata import PackageNotFoundError, version
    try:
        return version("lantern")
    except PackageNotFoundError:
        return "unknown"
