"""Benchmark: how fast the package and the command start (hyperfine-style: fresh processes,
interleaved, medians and minima), against the bare interpreter.

* ``python -c pass`` (the floor), ``python -c "import ufmt"``, ``python -m ufmt.cli
  --version`` and ``python -m ufmt.cli modes --help`` (the full parser), ROUNDS rounds.
* The modules ``import ufmt`` loads beyond the standard library, from ``python -X
  importtime`` (numpy, scipy and the physics stages must not be among them).
Targets: ``import ufmt`` <= 0.3 s and ``ufmt --version`` <= 0.3 s. Printed, never asserted.
"""

import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
ROUNDS = 10
COMMANDS = {
    "python -c pass": ["-c", "pass"],
    "import ufmt": ["-c", "import ufmt"],
    "ufmt --version": ["-m", "ufmt.cli", "--version"],
    "ufmt modes --help": ["-m", "ufmt.cli", "modes", "--help"],
}


def main() -> None:
    times: dict = {name: [] for name in COMMANDS}
    for _ in range(ROUNDS):
        for name, args in COMMANDS.items():
            t0 = time.perf_counter()
            subprocess.run([sys.executable, *args], cwd=ROOT, check=True, capture_output=True)
            times[name].append(time.perf_counter() - t0)
    for name, t in times.items():
        print(
            f"{name:18s} median {statistics.median(t):.3f} s  min {min(t):.3f} s  ({ROUNDS} runs)"
        )
    trace = subprocess.run(
        [sys.executable, "-X", "importtime", "-c", "import ufmt"],
        cwd=ROOT,
        check=True,
        capture_output=True,
        text=True,
    ).stderr
    heavy = sorted(
        {
            line.split("|")[-1].strip().split(".")[0]
            for line in trace.splitlines()[1:]
            if line.split("|")[-1].strip().split(".")[0] in ("numpy", "scipy", "pandas")
            or line.split("|")[-1].strip().startswith("ufmt.")
        }
    )
    print(f"import ufmt loads: {', '.join(heavy) or 'none of numpy, scipy, pandas, ufmt.*'}")
    print("targets: import ufmt <= 0.3 s, ufmt --version <= 0.3 s")


if __name__ == "__main__":
    main()
