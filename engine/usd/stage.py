"""A Usd.Stage kept as a Scene (engine/scene.py) for as long as a Session lives:
StageReader, the one class the Session talks to, over the reader's four jobs.

The first sync reads every prim (read.py, read_instancers.py, read_shading.py). It
also sorts what it read into static and dynamic (timeline.py): a record is read again
at a new time only when something it depends on may vary in time. Later syncs read
only the prims that Usd.Notice.ObjectsChanged reported (changes.py) and, at a new
time, the dynamic records: transforms, time-sampled meshes, skeleton poses,
blend-shape weights, lights, time-varying materials and visibility. Meshes whose
material emits are lights too (engine/emitters.py). What is read is
checked as it is read (validate.py). Each sync returns `Changes`, what it replaced,
and counts the prims it read.

Traversal includes instance proxies and skips abstract (`class`) and invisible prims.
Meshes sharing their data (same strongest `points` spec, same materials) share one
MeshData. A malformed mesh is skipped with a warning naming it."""
from __future__ import annotations

from pxr import Usd, UsdGeom

from ..emitters import Emitters
from ..scene import Changes, Scene
from . import camera as usd_camera
from .camera import time_code
from .changes import ChangeTracker, EditTracking
from .gprims import undrawn_warnings
from .read import FirstRead
from .read_instancers import InstancerReading
from .read_shading import ShadingReading
from .timeline import TimeSampling


UNDRAWN = "<undrawn>"            # scene.warnings key of the prim types not drawn


class StageReader(FirstRead, InstancerReading, ShadingReading, EditTracking, TimeSampling):
    """One stage's records and what is needed to keep them current; each job's
    methods live in the module named for it, and share the state set up here."""

    def __init__(self, stage: Usd.Stage, tessellate: bool = False):
        self.stage = stage
        self.tessellate = tessellate  # subdivision surfaces as patches for the GPU
        self.scene = Scene()
        self.tracker = ChangeTracker(stage)
        self.time = None              # the last sync's frame (None: Default)
        self.skel = None
        self._synced = False
        self._inst = {}               # instance path -> Dynamic (timeline.py)
        self._users = {}              # mesh key -> instance paths drawing it
        self._built = set()           # mesh keys built during this sync
        self._material_users = {}     # material name -> instance paths
        self._material_varies = {}    # Material prim path -> it may vary in time
        self._skels = {}              # skel key -> SkeletonState (read.py)
        self._shape_queries = {}
        self._light_prims = {}        # every UsdLux prim -> may vary in time (None: not asked yet)
        self._domes = {}              # dome prim path -> Dome
        self._cameras = []            # camera prim paths, traversal order
        self._visibility = {}         # prims whose own visibility may vary -> last value
        self._xform_memo = {}
        self._read = set()
        self._lights_moved = False    # lights added or removed: their order to restore
        self._retry = set()           # meshes skipped for a non-finite time-varying transform
        self._instancers = {}         # PointInstancer path -> InstancerState
        self._points = {}             # Points prim (and curve tubes) path -> it may vary in time
        self._gprims = {}             # gprim path -> its type, drawn or not
        self._undrawn = {}            # path -> type of the gprims (and unknown types) not drawn
        self.settings_changed = False  # /Render/Settings edited since the last sync
        self.emitters = Emitters()    # the lights of meshes whose material emits

    def close(self):
        self.tracker.close()

    # --- the one entry point ---------------------------------------------------------
    def _read_bounces(self):
        lines = []
        self.scene.bounces = usd_camera.bounces(self.stage, lines)
        if lines:
            self.scene.warnings[usd_camera.RENDER_SETTINGS] = lines
        else:
            self.scene.warnings.pop(usd_camera.RENDER_SETTINGS, None)

    def sync(self, frame) -> Changes:
        """Brings the scene to `frame` (None: Default time) and the stage's current
        edits; returns what changed."""
        changes = Changes()
        self._read = set()
        self._built = set()
        t = time_code(frame)
        self._xcache = UsdGeom.XformCache(t)
        self._op_memo, self._orient_memo = {}, {}
        self._t = t
        first = not self._synced
        if first:
            self.tracker.take()
            self._read_all(changes)
        else:
            resynced, changed = self.tracker.take()
            moved_in_time = frame != self.time
            if resynced or changed:
                self._xform_memo.clear()
                self._apply_edits(resynced, changed, changes)
            if moved_in_time:
                self._advance(changes)
        self.time = frame
        if first or self.settings_changed:
            self._read_bounces()
        self.emitters.sync(self.scene, changes, everything=first)
        self._finish_lights(changes)
        lines = undrawn_warnings(self._undrawn)
        if lines:
            self.scene.warnings[UNDRAWN] = lines
        else:
            self.scene.warnings.pop(UNDRAWN, None)
        changes.prims_read = len(self._read)
        return changes

    def gprims(self) -> dict:
        """{type name: count} of the gprims read (drawn or not) and prims of unknown
        type, for what a blank image says was there."""
        counts = {}
        for type_name in self._gprims.values():
            counts[type_name] = counts.get(type_name, 0) + 1
        return dict(sorted(counts.items()))

    def cameras(self) -> list:
        """Camera prim paths in traversal order."""
        return list(self._cameras)
