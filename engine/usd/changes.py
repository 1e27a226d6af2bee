"""Edits to a stage, collected between renders through Usd.Notice.ObjectsChanged (the
notice Hydra and usdview listen to): resynced paths (prims added, removed or
recomposed, properties created or removed) and info-only paths (values changed).
Notices arrive on the thread that edits the stage; `take` hands them to the reader."""
from __future__ import annotations

import threading

from pxr import Tf, Usd


class ChangeTracker:
    def __init__(self, stage: Usd.Stage):
        self._lock = threading.Lock()
        self._resynced: set = set()
        self._changed: set = set()
        self._listener = Tf.Notice.Register(Usd.Notice.ObjectsChanged, self._on_change, stage)

    def _on_change(self, notice, stage):
        resynced = notice.GetResyncedPaths()
        changed = notice.GetChangedInfoOnlyPaths()
        with self._lock:
            self._resynced.update(str(p) for p in resynced)
            self._changed.update(str(p) for p in changed)

    def take(self):
        """(resynced, changed) path strings since the last take."""
        with self._lock:
            out = self._resynced, self._changed
            self._resynced, self._changed = set(), set()
        return out

    def close(self):
        if self._listener is not None:
            self._listener.Revoke()
            self._listener = None
