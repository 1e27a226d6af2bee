"""The one error the exporters raise: it names the file or object and the reason."""
import numpy as np


class ExportError(Exception):
    """The input could not be read or the output could not be written."""


def require_finite(values, owner, what):
    """Raises ExportError when `values` hold NaN or Inf: such data would poison every
    renderer downstream, so nothing is written. `owner` names the object."""
    values = np.asarray(values)
    if values.size and not np.isfinite(values).all():
        bad = int(values.size - np.count_nonzero(np.isfinite(values)))
        raise ExportError(f"{owner}: {bad} non-finite (NaN or Inf) values in its {what}; "
                          "nothing was written")
