"""The one way Lantern opens a USD stage (the CLI, farm workers and the engine): a file,
or a stage sent as text, with pxr's reasons on one line when it cannot."""
from __future__ import annotations

from pxr import Sdf, Tf, Usd

from ...core.text import error_text, one_line


class UnreadableStage(OSError):
    """USD cannot open the file or text; the message names it and says why."""


def open_stage(path) -> Usd.Stage:
    try:
        stage = Usd.Stage.Open(str(path))
    except Tf.ErrorException as error:
        raise UnreadableStage(f"{path}: cannot be read as USD: "
                              f"{one_line(error_text(error))}") from error
    if stage is None:
        raise UnreadableStage(f"{path}: cannot be read as USD")
    return stage


def stage_from_text(text: str, name: str) -> Usd.Stage:
    """A stage from USD text (a .blend exported by the client, sent to a worker);
    `name` is the file the text came from, for messages."""
    layer = Sdf.Layer.CreateAnonymous(".usda")
    if not layer.ImportFromString(text):
        raise UnreadableStage(f"{name}: the exported stage could not be read back")
    return Usd.Stage.Open(layer)


def composition_errors(stage: Usd.Stage) -> list:
    """What USD could not compose (missing or broken references, sublayers, payloads,
    cycles), one line each."""
    return [one_line(error_text(error)) for error in stage.GetCompositionErrors()]
