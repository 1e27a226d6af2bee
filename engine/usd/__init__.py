"""The engine's USD side, and the only code in the engine that imports pxr: a stage
read into plain scene records (engine/scene.py), kept current through Usd.Notice and
re-read at each new time only where the stage varies in time."""
