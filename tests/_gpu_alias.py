"""A Dask worker preload for tests/test_gpus.py: on a machine with one EGL device (here,
llvmpipe), makes device 1 stand for device 0, so that two workers given different
LANTERN_GPU values both get a context and the test can check which device each task
says it drew on (the assignment, not the hardware).

Dask imports it in each worker process before the worker's first task
(`preload=[this file]`)."""
from dataclasses import replace

from lantern.engine.gpu import devices


def _alias():
    real, make = devices.egl_devices(), devices.make_backend
    devices.egl_devices = lambda: real + tuple(replace(d, index=d.index + len(real)) for d in real)
    devices.make_backend = lambda index, glversion: make(index % len(real), glversion)
    devices.aliased_for_tests = True


if not getattr(devices, "aliased_for_tests", False):   # Dask may load a preload twice
    _alias()
