#!/usr/bin/env python3
"""Time `mrfeel.Model.predict` on 100,000 samples (the paper's device; an 8 mm sine at 1.5 Hz at 1 kHz, the
current stepping from 0.2 A to 0.8 A every 10 s): the Python side of `cargo bench --bench predict`, whose
`predict/100k/from_columns` is the same work in Rust. Prints the best and the median of the repeats.

    python python/bench_predict.py [--repeat 20]
"""

import argparse
import pathlib
import timeit

import numpy as np

import mrfeel

ROOT = pathlib.Path(__file__).resolve().parents[1]

parser = argparse.ArgumentParser()
parser.add_argument("--repeat", type=int, default=20)
args = parser.parse_args()

model = mrfeel.Model.load(ROOT / "models" / "paper-device.toml")
t = np.arange(100_000) * 1e-3
x = 0.008 * np.sin(2 * np.pi * 1.5 * t)
i = np.where(np.floor(t / 10.0) % 2 == 0, 0.2, 0.8)
times = timeit.repeat(lambda: model.predict(t, x, i), number=1, repeat=args.repeat)
print(
    f"mrfeel.Model.predict, 100,000 samples: best {min(times) * 1e3:.2f} ms, "
    f"median {np.median(times) * 1e3:.2f} ms over {args.repeat} runs"
)
