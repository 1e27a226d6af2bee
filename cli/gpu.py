"""Which GPU `lantern render` draws on: --gpu N or $LANTERN_GPU, checked against this
machine's EGL devices before any work (--gpu list prints them), and the line --debug
prints of the GL the engine got."""
import argparse
import os

from .common import usage


def add_option(render):
    render.add_argument("--gpu", action=GPUAction, default=None, metavar="N|list",
                        help="draw on EGL device N, and stop if it is a software "
                             "rasteriser (default: $LANTERN_GPU, else the first GPU); "
                             "'list' prints the devices")


class GPUAction(argparse.Action):
    """--gpu N, or --gpu list: print this machine's devices and exit (like --version,
    before the other arguments are checked)."""

    def __call__(self, parser, namespace, values, option_string=None):
        if values != "list":
            setattr(namespace, self.dest, values)
            return
        from ..engine.gpu.devices import table
        lines = table()
        print("\n".join(lines) if lines else "no EGL devices (lantern draws on the "
                                              "platform's default GL context)")
        parser.exit()


def check_gpu(args):
    """--gpu N, or LANTERN_GPU: a device of this machine (else a usage error naming
    them), passed on as LANTERN_GPU to the engine and to local workers. Dask workers
    elsewhere take their own LANTERN_GPU where they start."""
    given = args.gpu
    if given is not None and args.scheduler not in (None, "local"):
        raise usage(f"--gpu {given}: chooses this machine's GPU; a Dask worker takes the "
                     "LANTERN_GPU set where it starts")
    text = given if given is not None else os.environ.get("LANTERN_GPU", "").strip()
    if not text or (given is None and args.scheduler not in (None, "local")):
        return
    name = f"--gpu {text}" if given is not None else f"LANTERN_GPU={text}"
    if not text.isdigit():
        raise usage(f"{name}: must be a device number or 'list'")
    from ..engine.gpu.devices import DeviceError, check_exists, egl_devices
    if not egl_devices():
        raise usage(f"{name}: this machine lists no EGL devices to choose from")
    try:
        check_exists(int(text), name)
    except DeviceError as error:
        raise usage(str(error))
    os.environ["LANTERN_GPU"] = str(int(text))


def gl_line(stats) -> str:
    """--debug: the GL the engine got, on which device, and the paths it took."""
    from ..engine.gpu.budget import gib
    device = stats.get("gpu_device")
    where = "" if device is None else f" on EGL device {device} of {stats.get('gpu_devices')}"
    free, total = stats.get("gpu_memory_free"), stats.get("gpu_memory_total")
    memory = "" if free is None else (
        f"; memory: {gib(free)} free" + (f" of {gib(total)}" if total else "")
        + f" ({stats.get('gpu_memory_source')})")
    return (f"  GL: {stats.get('gl_renderer')}, {stats.get('gl_version')} (asked for "
            f"{stats.get('gl_requested', 0) / 100:.1f}){where}{memory}; "
            f"paths: {stats.get('gl_path')}")
