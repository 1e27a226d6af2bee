"""The bundled demo: a scene built from a script, exported and rendered by the CLI."""
