"""The worker-local cache of engine Sessions.

A worker keeps one Session per stage and render settings across the chunks it renders,
so only its first chunk pays for reading the stage, uploading it and compiling shaders;
every later frame is a warm render (only what varies in time is read again). The key is
the stage file with its mtime and size (a stage that changed on disk is loaded anew and
the stale session released) or, for a stage sent as text, its digest; plus the
settings. The cache is released when the worker closes (`release_all`: the Dask worker
plugin's teardown, or the pool process's last message).
"""
from __future__ import annotations

import os
import threading
import time
from collections import OrderedDict

KEEP = 2  # sessions kept per worker: each holds a stage's GPU buffers and shadow maps

_lock = threading.Lock()
_sessions: OrderedDict = OrderedDict()


def _source_key(task):
    if task.stage_digest is not None:
        return ("text", task.stage_digest)
    stat = os.stat(task.scene)
    return (os.path.abspath(task.scene), stat.st_mtime_ns, stat.st_size)


def session_for(task, stage_text=None):
    """(Session, seconds it took to load) for the chunk's stage and settings; the
    seconds are None when the session was already here."""
    source = _source_key(task)
    key = (source, task.settings_key)
    with _lock:
        if key in _sessions:
            _sessions.move_to_end(key)
            return _sessions[key], None
        # The same file at another mtime/size is stale: release its sessions now.
        for old in [k for k in _sessions if k[0][0] == source[0] and k[0] != source]:
            _sessions.pop(old).close()
    start = time.perf_counter()
    session = _open(task, stage_text)
    seconds = time.perf_counter() - start
    with _lock:
        _sessions[key] = session
        while len(_sessions) > KEEP:
            _sessions.popitem(last=False)[1].close()
    return session, seconds


def _open(task, stage_text):
    from ..engine import RenderSettings, Session
    from ..engine.usd.opening import open_stage, stage_from_text
    if task.stage_digest is not None:
        if stage_text is None:
            raise ValueError(f"{task.scene}: the stage's text did not reach the worker")
        stage = stage_from_text(stage_text, task.scene)
    else:
        stage = open_stage(task.scene)
    first = task.targets[0]
    settings = RenderSettings(width=first.width, height=first.height, preset=task.preset,
                              camera=first.camera)
    return Session(stage, settings)


def cached():
    """How many sessions this process holds (for tests)."""
    return len(_sessions)


def release_all():
    with _lock:
        while _sessions:
            _sessions.popitem()[1].close()
