"""Batch export and sequence rendering as tasks, on this machine or on a Dask cluster.

- `options.py`: what the CLI tells a batch (FarmOptions and the export and sequence
  records), built once from the command line.
- `tasks.py`: the two tasks (export one .blend file, render a chunk of frames) and what a
  worker does with each.
- `sessions.py`: the worker-local cache of engine Sessions, so a chunk costs warm renders.
- `chunking.py`: chunk sizes from the measured cold, warm and per-task costs.
- `runners.py`: where tasks run: the local process pool, or a Dask cluster (an embedded
  LocalCluster or an existing scheduler).
- `batch.py`: the client: resume, submit, retries, collected outputs, progress and summary.

Imports nothing heavy at package level: pool workers import only what their task needs.
"""
