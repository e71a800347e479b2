"""Read a OnePiece-Dist dataset with zarr and numpy only (no onepiece_dist import).

Usage: python examples/read_dataset_with_zarr.py onepiece-out/dataset.zarr
"""

import sys

import numpy as np
import zarr


def main(path: str) -> None:
    root = zarr.open_group(path, mode="r")
    attrs = root.attrs.asdict()
    assert attrs["onepiece_format"] == 2 and attrs["complete"], "not a complete format-2 dataset"
    a, b, c = attrs["grid_shape"]
    names = [bytes(row).rstrip(b"\0").decode() for row in root["objects/name"][:]]
    codes = root["grasps/code"][:]
    code_index = root["grasps/code_index"][:]
    unique = root["unique/code"][:]
    counts = root["unique/count"][:]
    assert np.array_equal(unique[code_index], codes), "code_index must point at each grasp's code"
    assert counts.sum() == len(codes)
    occupancy = np.unpackbits(codes, axis=1, count=a * b * c, bitorder="big").reshape(-1, a, b, c)
    poses = root["grasps/pose"][:]
    print(f"objects: {len(names)} ({', '.join(names[:5])}{'...' if len(names) > 5 else ''})")
    print(f"grasps: {len(codes)}, unique codes: {len(unique)} ({len(unique) / max(len(codes), 1):.1%})")
    print(f"grid (u, v, t): {a} x {b} x {c}, mean occupied voxels: {occupancy.sum(axis=(1, 2, 3)).mean():.1f}")
    print(f"first pose (gripper in object frame):\n{np.round(poses[0], 3) if len(poses) else None}")
    print(f"rejected: {len(attrs['rejected'])}")
    if "assembled/grasps/points" in root:
        group = root["assembled/grasps"]
        local, inside = pointnetgpd_crop(group["points"][:64].astype(np.float64), group["width"][:64],
                                         attrs["gripper"]["closing_depth"])
        print(f"PointNetGPD crops of 64 labelled grasps: {inside.sum(axis=1).mean():.1f} points inside on average")


def pointnetgpd_crop(points, width, closing_depth):
    """Our gripper-frame points (n, P, 3) in PointNetGPD's training frame (u - closing_depth / 2, v, -t) and the
    (n, P) mask of those in its box |x| < w/4, |y| < w/2, |z| < w/4 (docs/dataset_format.md, Other formats)."""
    local = points * [1.0, 1.0, -1.0] - [closing_depth / 2, 0.0, 0.0]
    w = np.asarray(width, dtype=np.float64)[:, None, None]
    return local, np.all(np.abs(local) < np.concatenate([w / 4, w / 2, w / 4], axis=-1), axis=-1)


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "onepiece-out/dataset.zarr")
