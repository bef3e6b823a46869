"""The three thesis experiment groups (wind speed, anemometer error, wind
direction) with all four thesis methods (LS, LS+GA, SVM, SVM+GA) at the
thesis durations (4000 s training zig-zag at 0.1 s, 600 s validation
zig-zags): 48 jobs through the default parallel launcher into a fresh store.
It runs only when named (``studies bench sweep``): it takes minutes."""

import subprocess
import sys
import tempfile
import time


#: run only when named
ON_REQUEST = True


def run() -> dict:
    out = {}
    total = 0.0
    with tempfile.TemporaryDirectory() as tmp:
        for preset in ("thesis_wind_speed", "thesis_noise", "thesis_direction"):
            t0 = time.perf_counter()
            proc = subprocess.run([sys.executable, "-m", "studies", "run", f"experiment={preset}"],
                                  cwd=tmp, capture_output=True, text=True)
            elapsed = time.perf_counter() - t0
            if proc.returncode != 0:
                raise RuntimeError(f"{preset} failed: {proc.stderr[-2000:]}")
            out[f"sweep_{preset}_s"] = elapsed
            total += elapsed
    out["sweep_thesis_s"] = total
    return out
