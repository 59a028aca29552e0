"""Benchmark: PSD1 and PSD2 over the whole aperture, on line profiles against a full grid.

1. The packaged UFMT on its 52.4 mm plate, PSD bands at 0.03 mm two ways: today's full grid
   at 0.03 mm (``spacing=3e-5, line_spacing=None``: ~3e6 nodes, the most the grid cap allows
   on this plate) side by side with the line profiles (the default 1 x 1.25 mm grid for the
   maps and the PV, ``line_spacing=3e-5`` for the bands); the band values of both printed.
2. The packaged UFMT with ``workpiece_size = [0.41, 0.41]`` (a KDP plate): the bands on the
   grid's columns and rows (``line_spacing=None``: PSD2 unresolved) and on the line profiles
   at 0.03 mm (the default); the difference is what the lines cost. Target for the whole
   simulation with the lines (the default): PSD1 and PSD2 along and across the feed in
   <= 15 s wall and <= 1 GB peak resident set.

Each case runs ``ufmt.simulate`` once in a fresh process (300 rpm, 8 mm/min, 5 um) and prints
its CPU time (``time.process_time``: the machine is shared), its wall time and its peak
resident set (VmHWM).
"""

import json
import subprocess
import sys
import tempfile
from importlib import resources
from pathlib import Path

#: Samples per revolution of every case: the packaged model's default on its 1 mm grid (the
#: tool carrier's mode asks for the most allowed; the 0.03 mm grid's default would ask more).
N_PHI = 65536

CASE = """
import json, time
import ufmt
N_PHI = {n_phi}
from ufmt.machining.process import Process
wall, cpu = time.perf_counter(), time.process_time()
r = ufmt.simulate({model!r}, Process(300, 8, 5), n_phi=N_PHI, **{options!r})
cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
hwm = int(open("/proc/self/status").read().split("VmHWM:")[1].split()[0]) / 1024
keys = [k for k in r.metrics if k.startswith("psd") and k.endswith("_nm")]
print(json.dumps({{"cpu": cpu, "wall": wall, "hwm": hwm, **{{k: r.metrics[k] for k in keys}}}}))
"""


def run(model: str, options: dict) -> dict:
    """One simulation in a fresh interpreter: CPU [s], wall [s], peak RSS [MiB], bands [nm]."""
    code = CASE.format(model=model, options=options, n_phi=N_PHI)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    if done.returncode:
        raise RuntimeError(done.stderr.strip().splitlines()[-1])
    return json.loads(done.stdout.splitlines()[-1])


def row(name: str, r: dict) -> str:
    bands = " ".join(
        f"{k[:-3]} {r[k]:.4g}" if r[k] is not None else f"{k[:-3]} -"
        for k in ("psd1_rms_across_nm", "psd1_rms_along_nm")
        + ("psd2_rms_across_nm", "psd2_rms_along_nm")
    )
    return (
        f"  {name:34s} {r['cpu']:6.1f} s CPU {r['wall']:6.1f} s wall {r['hwm']:6.0f} MiB | {bands}"
    )


def plate_410(folder: Path) -> str:
    """The packaged model on a 0.41 m x 0.41 m plate, written to ``folder``."""
    text = (resources.files("ufmt") / "data" / "ufmt.toml").read_text()
    lines = [
        "workpiece_size = [0.41, 0.41]" if line.startswith("workpiece_size =") else line
        for line in text.splitlines()
    ]
    path = folder / "ufmt-410.toml"
    path.write_text("\n".join(lines) + "\n")
    return str(path)


if __name__ == "__main__":
    packaged = str(resources.files("ufmt") / "data" / "ufmt.toml")
    print("52.4 mm plate, bands at 0.03 mm:")
    print(row("full grid at 0.03 mm", run(packaged, {"spacing": 3e-5, "line_spacing": None})))
    print(row("line profiles at 0.03 mm", run(packaged, {"line_spacing": 3e-5})))
    with tempfile.TemporaryDirectory() as folder:
        model = plate_410(Path(folder))
        print("410 mm plate (target for the whole run with the lines: <= 15 s wall, <= 1 GB):")
        grid = run(model, {"line_spacing": None})
        lines = run(model, {"line_spacing": 3e-5})
        print(row("grid's columns and rows (1 mm)", grid))
        print(row("line profiles at 0.03 mm", lines))
        print(
            f"  the lines' cost: {lines['cpu'] - grid['cpu']:.1f} s CPU,"
            f" {lines['wall'] - grid['wall']:.1f} s wall, {lines['hwm'] - grid['hwm']:+.0f} MiB"
            " peak"
        )
