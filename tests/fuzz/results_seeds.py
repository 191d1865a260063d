#!/usr/bin/python3
"""Hand-made seeds of the results fuzz target (scripts/fuzz --seed runs this): files that
peristat does not write but HDF5 allows, each near a branch of the reader.
Usage: results_seeds.py VALID.h5 OUT_DIR"""
import sys

import h5py
import numpy as np

valid, out = sys.argv[1], sys.argv[2]


def copy_of(name):
    """A writable copy of the valid file."""
    path = f"{out}/hand-{name}.h5"
    with h5py.File(valid, "r") as src, h5py.File(path, "w") as dst:
        for key, value in src.attrs.items():
            dst.attrs[key] = value
        for key in src:
            src.copy(src[key], dst, name=key)
    return h5py.File(path, "r+")


# Fixed-length strings, other number types, chunked and compressed datasets.
with copy_of("types") as f:
    scene = f.attrs["scene"]
    del f.attrs["scene"]
    f.attrs.create("scene", np.bytes_(scene.encode() if isinstance(scene, str) else scene))
    p = f["particles"]
    names = [n.decode() if isinstance(n, bytes) else n for n in p.attrs["body_names"]]
    p.attrs.create("body_names", np.array([n.encode() for n in names], dtype="S8"))
    position = p["position"][...]
    del p["position"]
    p.create_dataset("position", data=position.astype(np.float32), chunks=(4, 2), compression="gzip")
    body = p["body"][...]
    del p["body"]
    p.create_dataset("body", data=body.astype(np.int64))
    fictitious = p["fictitious"][...]
    del p["fictitious"]
    p.create_dataset("fictitious", data=fictitious.astype(np.uint8))
    f["steps"]["000001"].attrs["load_factor"] = np.float32(0.5)

# No particles, and a step without data.
with copy_of("empty") as f:
    p = f["particles"]
    for key, shape in (("position", (0, 2)), ("volume", (0,)), ("body", (0,)), ("fictitious", (0,))):
        dtype = p[key].dtype
        del p[key]
        p.create_dataset(key, shape=shape, dtype=dtype)
    for step in f["steps"].values():
        del step["displacement"]
        step.create_dataset("displacement", shape=(0, 2), dtype="f8")
    f["steps"].create_group("000009")

# Odd values: a far particle, a negative body index, NaN displacement, an unnamed body.
with copy_of("values") as f:
    p = f["particles"]
    p["position"][0] = [1.0e12, -3.0]
    p["body"][1] = -7
    p["body"][2] = 5
    p.attrs["spacing"] = 1.0e-9
    f["steps"]["000002"]["displacement"][3] = [np.nan, np.inf]

# A step group that is a dataset, a dataset that is a group, a shape of another rank.
with copy_of("kinds") as f:
    steps = f["steps"]
    steps.create_dataset("000003", data=[1.0])
    del steps["000001"]["displacement"]
    steps["000001"].create_group("displacement")
    del steps["000002"]["damage"]
    steps["000002"].create_dataset("damage", data=np.zeros((2, 2, 2)))
    steps.create_group("notes")

# A dataset larger than the file: chunked, never written (HDF5 returns its fill value).
with copy_of("sparse") as f:
    step = f["steps"]["000002"]
    del step["displacement"]
    step.create_dataset("displacement", shape=(1 << 28, 2), dtype="f8", chunks=(1024, 2))
