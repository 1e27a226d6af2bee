"""`lantern render --timings`: the phases of a cold render, from the process's start to
the image written."""
import os
import time


class Phases:
    """--timings: the seconds of the phases of a render, as they pass."""

    def __init__(self, started):
        # started: (seconds from process start to main, or None; perf_counter at main).
        # The first phase counts from main: the command line's checks import too (the
        # colour check, NumPy and OpenColorIO).
        self.started = started
        self.seconds = {}
        self._last = started[1] if started is not None else time.perf_counter()

    def mark(self, name):
        now = time.perf_counter()
        self.seconds[name] = self.seconds.get(name, 0.0) + now - self._last
        self._last = now

    def report(self, scene, result):
        """Prints the phases, the render split by what the engine measured: its GL
        context and set-up, the scene read, the first frame (of which programs and
        uploads)."""
        t, s = result.timings, result.stats
        rows = []
        if self.started is not None:
            rows.append(("process start to main", self.started[0]))
        rows += [("imports", self.seconds.get("imports")),
                 ("stage open", self.seconds.get("stage open")),
                 ("GL context", t.get("context")), ("session setup", t.get("setup")),
                 ("scene read", t.get("load")),
                 ("programs", t.get("programs")), ("uploads", t.get("upload")),
                 ("first frame", t.get("total", 0.0) - t.get("load", 0.0)),
                 ("encode and write", self.seconds.get("encode and write"))]
        if self.started is not None and self.started[0] is not None:
            rows.append(("wall", self.started[0] + time.perf_counter() - self.started[1]))
        print(f"timings of {scene} (ms; programs and uploads are part of the first frame):")
        for name, seconds in rows:
            if seconds is not None:
                print(f"  {name:<24}{seconds * 1000:8.1f}")
        # Where a first frame's extra time lands: the CPU time issuing each pass holds
        # what the driver does on a program's first draw (llvmpipe's code generation).
        passes = sorted(((p, v) for p, v in t.items() if p in result.gpu_timings),
                        key=lambda pv: -pv[1])[:4]
        print("  first frame's heaviest passes (CPU / GPU ms): " + ", ".join(
            f"{p} {v * 1000:.0f} / {result.gpu_timings[p] * 1000:.0f}" for p, v in passes))
        print(f"  programs: {s.get('programs_compiled', 0)} compiled, "
              f"{s.get('programs_loaded', 0)} loaded from the program cache")


def seconds_since_start():
    """Wall seconds since this process started, from /proc (Linux, to 10 ms); None
    elsewhere."""
    try:
        with open("/proc/self/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        with open("/proc/uptime") as f:
            uptime = float(f.read().split()[0])
        return max(uptime - int(fields[19]) / os.sysconf("SC_CLK_TCK"), 0.0)
    except (OSError, ValueError, IndexError, AttributeError):
        return None
