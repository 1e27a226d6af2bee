"""The engine's one-call entry points, each a thin user of a Session."""
from __future__ import annotations

import numpy as np

from .session import RenderResult, Session
from .settings import RenderSettings
from .usd.opening import open_stage


def render_stage(stage, settings: RenderSettings | None = None) -> RenderResult:
    """One image of a Usd.Stage."""
    with Session(stage, settings) as session:
        return session.render()


def render_file(path: str, settings: RenderSettings | None = None) -> RenderResult:
    return render_stage(open_stage(path), settings)


def render_sequence(stage, first: float, last: float,
                    settings: RenderSettings | None = None):
    """Yields (frame, RenderResult) for frames first..last with one Session: the
    stage's static data is read and uploaded once, each frame reads only what varies
    in time, and frame N+1 is drawn while frame N is copied (Session.render_frames)."""
    if last < first:
        raise ValueError(f"empty frame range {first}:{last}")
    with Session(stage, settings) as session:
        frames = [float(f) for f in np.arange(first, last + 0.5, 1.0)]
        for frame, result in session.render_frames(frames):
            if isinstance(result, Exception):
                raise result
            yield frame, result


def skinned_points(stage, frame: float) -> dict:
    """GPU-skinned points and normals of every skinned mesh at `frame` (see
    Session.skinned_points)."""
    with Session(stage, RenderSettings(width=1, height=1, preset="low")) as session:
        return session.skinned_points(frame)
