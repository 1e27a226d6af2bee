"""What a batch needs to know from the command line, as plain frozen records that the
CLI builds once (farm/ never reads argparse's namespace)."""
from __future__ import annotations

from dataclasses import dataclass

from ..core.subdivision_modes import FILE_DEFAULT


@dataclass(frozen=True, kw_only=True)
class FarmOptions:
    """Where the tasks run, and what to skip or bring back."""
    scheduler: str | None = None    # a Dask scheduler address, 'local', or None (a process pool)
    jobs: int = 1                   # processes on this machine (no scheduler)
    collect: bool = False           # workers send the outputs back; this process writes them
    resume: bool = False            # skip outputs newer than their input
    # Called with one word per state ("running": the first tasks are on the workers;
    # "finished"), for `--status-fd`; None: nothing reported.
    status: object = None


@dataclass(frozen=True, kw_only=True)
class ExportBatchOptions(FarmOptions):
    """`lantern export` with a folder for -o."""
    textures: str = "reference"
    max_influences: int | None = None
    subdivision: str = FILE_DEFAULT  # core/subdivision_modes.py


@dataclass(frozen=True)
class Product:
    """One file of every frame: `lantern render -o`, or a RenderProduct of the stage."""
    output: str                     # a name with '####', or a .gif
    size: tuple | None = None       # (width, height), or the stage's own
    camera: str | None = None
    passes: tuple = ()              # render passes (core/passes.py names)
    layer: str = "ViewLayer"        # the view layer its layers are named after
    multilayer: bool = False        # a multi-layer EXR even with no passes (a RenderProduct)
    product: str | None = None      # the RenderProduct prim it renders; None: -o's image

    @property
    def layered(self) -> bool:
        """Written as a multi-layer EXR (engine/image_io.py write_layers)."""
        return bool(self.passes) or self.multilayer

    @property
    def origin(self) -> str:
        """Where it comes from, for the lines printed: the stage's RenderProduct, or
        the command line's -o."""
        return "-o" if self.product is None else f"RenderProduct {self.product}"


@dataclass(frozen=True, kw_only=True)
class SequenceOptions(FarmOptions):
    """`lantern render --frames`."""
    scene: str                      # the file the user named
    products: tuple                 # Product, at least one; a .gif only alone
    frames: tuple                   # the frames, in order
    preset: str = "medium"
    chunk: int | None = None        # frames per task; None: from the measured costs
    # Blender's colour management for display outputs (engine/color.py).
    view: str = "Standard"
    look: str | None = None
    exposure: float = 0.0
    overlays: object = None         # engine/overlays.py BurnIn, drawn on each .png; or None

    @property
    def output(self):
        """The first product's file: where messages point."""
        return self.products[0].output

    @property
    def colour(self):
        """The view settings as write_image's keywords."""
        return dict(view=self.view, look=self.look, exposure=self.exposure)
