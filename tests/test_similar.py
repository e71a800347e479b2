import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from onepiece_dist.core.dedup import unique_codes
from onepiece_dist.core.similar import brute_force_pairs, candidate_pairs, hamming, similar_clusters


def clustered_codes(seed: int, n: int, nbytes: int, flips: int) -> np.ndarray:
    """Random prototypes plus copies with a few flipped bits, so that radii 1-4 link some codes."""
    rng = np.random.default_rng(seed)
    protos = rng.integers(0, 256, (max(1, n // 4), nbytes), dtype=np.uint8)
    codes = protos[rng.integers(0, len(protos), n)]
    bits = np.unpackbits(codes, axis=1)
    for row in range(n):
        bits[row, rng.integers(0, bits.shape[1], rng.integers(0, flips + 1))] ^= 1
    return unique_codes(np.packbits(bits, axis=1)).unique


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 10_000), st.integers(2, 80), st.sampled_from([1, 2, 8]), st.sampled_from([0, 1, 2, 4]))
def test_index_finds_every_pair_within_the_radius(seed, n, nbytes, radius):
    codes = clustered_codes(seed, n, nbytes, flips=radius + 1)
    nbits = nbytes * 8
    every = brute_force_pairs(len(codes))
    near = every[hamming(codes[every[:, 0]], codes[every[:, 1]]) <= radius] if len(every) else every
    found = candidate_pairs(codes, nbits, radius) if radius else np.zeros((0, 2), np.int64)
    assert {tuple(p) for p in near} <= {tuple(p) for p in found} or radius == 0
    counts = np.random.default_rng(seed).integers(1, 5, len(codes))
    indexed = similar_clusters(codes, counts, nbits, radius)
    reference = similar_clusters(codes, counts, nbits, radius, pairs=every)
    assert np.array_equal(indexed.cluster, reference.cluster)
    assert np.array_equal(indexed.representative, reference.representative)
    assert indexed.counts.sum() == counts.sum()


def test_radius_zero_is_exact_dedup_and_members_stay_near_their_links():
    codes = clustered_codes(1, 200, 8, flips=2)
    counts = np.ones(len(codes), dtype=np.int64)
    exact = similar_clusters(codes, counts, 64, 0)
    assert len(exact.representative) == len(codes)
    merged = similar_clusters(codes, counts, 64, 2)
    assert len(merged.representative) < len(codes)
    order = np.random.default_rng(0).permutation(len(codes))  # shard order does not matter
    shuffled = similar_clusters(codes[order], counts[order], 64, 2)
    assert {codes[r].tobytes() for r in merged.representative} == {
        codes[order][r].tobytes() for r in shuffled.representative}
    # every member is linked to its cluster through codes at most 2 bits apart
    for c in range(len(merged.representative)):
        members = codes[merged.cluster == c]
        if len(members) > 1:
            nearest = [np.sort(hamming(members, np.repeat(m[None], len(members), 0)))[1] for m in members]
            assert max(nearest) <= 2


def test_a_job_with_a_radius_maps_every_grasp_to_its_cluster_representative(spec_factory):
    from onepiece_dist.runtime.local import run_local
    from onepiece_dist.store import open_dataset

    exact = run_local(spec_factory())
    spec = spec_factory(similar_radius=2, output=exact.output.replace(".zarr", "_r2.zarr"))
    merged = run_local(spec)
    ds = open_dataset(spec.output)
    assert merged.progress.unique_codes < exact.progress.unique_codes
    codes = ds["grasps/code"]
    assert np.array_equal(ds["exact/code"][ds["grasps/exact_index"]], codes)
    assert np.array_equal(ds["exact/cluster"][ds["grasps/exact_index"]], ds["grasps/code_index"])
    assert ds["unique/count"].sum() == len(codes)


def test_sparse_codes_sharing_a_block_of_zeros_get_few_candidate_pairs_and_the_same_clusters():
    rng = np.random.default_rng(3)
    bits = np.zeros((1500, 64), dtype=np.uint8)
    for row in bits:  # every code empty in its first half, a few voxels set in the second
        row[32 + rng.choice(32, rng.integers(1, 6), replace=False)] = 1
    codes = unique_codes(np.packbits(bits, axis=1)).unique
    every = brute_force_pairs(len(codes))
    counts = rng.integers(1, 5, len(codes))
    for radius in (1, 2):
        near = every[hamming(codes[every[:, 0]], codes[every[:, 1]]) <= radius]
        found = candidate_pairs(codes, 64, radius)
        assert {tuple(p) for p in near} <= {tuple(p) for p in found}
        assert len(found) < len(every) / 4  # one block index alone would propose every pair (all share the zeros)
        indexed = similar_clusters(codes, counts, 64, radius)
        reference = similar_clusters(codes, counts, 64, radius, pairs=every)
        assert np.array_equal(indexed.cluster, reference.cluster)
        assert np.array_equal(indexed.representative, reference.representative)
