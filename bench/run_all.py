"""Runs every benchmark in this folder, each in its own process (bpy holds one scene)."""
import pathlib
import subprocess
import sys

HERE = pathlib.Path(__file__).parent
failed = 0
for script in sorted(HERE.glob("bench_*.py")):
    print(f"== {script.name}", flush=True)
    failed += subprocess.run([sys.executable, str(script)]).returncode != 0
sys.exit(1 if failed else 0)
