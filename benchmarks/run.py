"""Run every benchmark (make bench): each prints its measured figures against its target."""

import runpy
import sys
from pathlib import Path

HERE = Path(__file__).parent

if __name__ == "__main__":
    sys.path.insert(0, str(HERE))
    from ufmt.allocator import retain_freed_memory

    retain_freed_memory()  # the heap as the CLI and the study workers keep it, for every side
    for script in sorted(HERE.glob("bench_*.py")):
        print(f"== {script.stem} ==", flush=True)
        runpy.run_path(str(script), run_name="__main__")
        print(flush=True)
