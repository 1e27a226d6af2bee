"""Text for people: one-line error messages (pxr's multi-line errors, messages that are
not UTF-8) and the frame-number pattern of sequence file names ('####')."""
from __future__ import annotations

import math
import re

_PXR_ERROR = re.compile(r"^Error in '.*' at line \d+ in file .* : '(.*)'$")


def error_text(error):
    """str(error), even when pxr's message holds bytes that are not UTF-8 (a damaged
    file's contents quoted in a parse error)."""
    try:
        return str(error)
    except UnicodeDecodeError:
        return f"{type(error).__name__} (its message is not UTF-8 text: the file is damaged)"


def one_line(text):
    """pxr's errors span lines ("Error in '...' at line N in file F : 'reason'"): keep
    the reasons, on one line."""
    reasons = []
    for line in str(text).splitlines():
        line = line.strip()
        match = _PXR_ERROR.match(line)
        reasons.append(match.group(1) if match else line)
    return "; ".join(dict.fromkeys(r for r in reasons if r)) or "no reason given"


def frame_path(pattern, frame):
    """'####' (any run of #) -> the frame zero-padded to that width; a fractional frame
    keeps its fraction after the padded whole part (0012.5)."""
    whole = math.floor(frame)
    fraction = f"{frame - whole:.6f}".rstrip("0").rstrip(".")[1:] if frame != whole else ""
    return re.sub(r"#+", lambda m: f"{int(whole):0{len(m.group(0))}d}{fraction}", pattern, count=1)
