import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from onepiece_dist.core.dedup import DedupIndex, PartitionedDedup, merge_partitions, merge_unique, unique_codes


def brute_force(codes):
    seen = {}
    for row in codes:
        seen[row.tobytes()] = seen.get(row.tobytes(), 0) + 1
    keys = sorted(seen)
    return keys, [seen[k] for k in keys]


code_sets = st.integers(1, 20).flatmap(
    lambda nbytes: arrays(np.uint8, st.tuples(st.integers(0, 200), st.just(nbytes)),
                          elements=st.integers(0, 255) if nbytes > 2 else st.integers(0, 3)))


@settings(max_examples=150, deadline=None)
@given(code_sets)
def test_unique_equals_brute_force(codes):
    result = unique_codes(codes)
    keys, counts = brute_force(codes)
    assert [r.tobytes() for r in result.unique] == keys
    assert result.counts.tolist() == counts
    assert np.array_equal(result.unique[result.inverse], codes)


@settings(max_examples=100, deadline=None)
@given(code_sets, st.sampled_from(["zeros", "low_bit", "first_byte"]))
def test_forced_hash_collisions_never_merge_different_codes(codes, kind):
    colliding = {"zeros": lambda w: np.zeros(len(w), np.uint64),
                 "low_bit": lambda w: w[:, 0] & np.uint64(1),
                 "first_byte": lambda w: w[:, 0] >> np.uint64(56)}[kind]
    plain, weak = unique_codes(codes), unique_codes(codes, hash_fn=colliding)
    assert np.array_equal(plain.unique, weak.unique)
    assert np.array_equal(plain.counts, weak.counts)
    assert np.array_equal(plain.inverse, weak.inverse)
    assert np.array_equal(weak.unique[weak.inverse], codes)


@settings(max_examples=60, deadline=None)
@given(code_sets, st.integers(1, 4), st.randoms(use_true_random=False))
def test_merging_shards_in_any_order_gives_the_same_set(codes, nshards, random):
    cuts = sorted(random.randint(0, len(codes)) for _ in range(nshards - 1))
    shards = np.split(codes, cuts)
    parts = [(u.unique, u.counts) for u in map(unique_codes, shards)]
    whole = unique_codes(codes)
    for perm in itertools.islice(itertools.permutations(range(len(parts))), 6):
        merged, remaps = merge_unique([parts[i] for i in perm])
        assert np.array_equal(merged.unique, whole.unique) and np.array_equal(merged.counts, whole.counts)
        for i, remap in zip(perm, remaps, strict=True):
            assert np.array_equal(merged.unique[remap], parts[i][0])


def test_running_index_matches_one_shot_and_looks_up_codes():
    rng = np.random.default_rng(0)
    codes = rng.integers(0, 3, (1000, 9)).astype(np.uint8)
    index = DedupIndex(9)
    for chunk in np.array_split(codes, 7)[::-1]:
        index.add(chunk)
    whole = unique_codes(codes)
    assert np.array_equal(index.unique, whole.unique) and np.array_equal(index.counts, whole.counts)
    assert np.array_equal(index.lookup(codes), whole.inverse)


@settings(max_examples=80, deadline=None)
@given(code_sets, st.integers(1, 12), st.integers(1, 40))
def test_log_structured_index_equals_one_shot_whatever_the_flush_size(codes, batches, flush_rows):
    index = DedupIndex(codes.shape[1], flush_rows=flush_rows)
    for chunk in np.array_split(codes, batches):
        index.add(chunk)
    whole = unique_codes(codes)
    assert np.array_equal(index.unique, whole.unique) and np.array_equal(index.counts, whole.counts)
    if len(codes):
        assert np.array_equal(index.lookup(codes), whole.inverse)


@pytest.mark.parametrize("nbytes", [8, 9])
def test_lookup_of_a_code_never_added_raises(nbytes):
    index = DedupIndex(nbytes)
    index.add(np.zeros((3, nbytes), np.uint8))
    with pytest.raises(KeyError, match="never added"):
        index.lookup(np.ones((1, nbytes), np.uint8))


@settings(max_examples=60, deadline=None)
@given(code_sets, st.integers(1, 5))
def test_partitioned_dedup_gives_exactly_the_single_index_result(codes, partitions):
    single, split = DedupIndex(codes.shape[1]), PartitionedDedup(codes.shape[1], partitions)
    for chunk in np.array_split(codes, 3):
        single.add(chunk)
        split.add(chunk)
    merged = split.merged()
    assert np.array_equal(merged.unique, single.unique) and np.array_equal(merged.counts, single.counts)
    owners = [set(map(bytes, shard.unique)) for shard in split.shards]
    assert sum(map(len, owners)) == len(single)  # disjoint: every code lives in exactly one partition


@pytest.mark.ray
def test_dedup_shard_actors_on_ray_match_one_index(ray_session):
    from benchmarks.speed.dedup_partitions import DedupPartition, route_codes

    codes = np.random.default_rng(4).integers(0, 4, (20000, 8)).astype(np.uint8)
    shards = [ray_session.remote(num_cpus=0)(DedupPartition).remote(8, k, 3) for k in range(3)]
    for chunk in np.array_split(codes, 10):
        ray_session.get([s.add.remote(part) for s, part in zip(shards, route_codes(chunk, 3), strict=True)])
    merged = merge_partitions(ray_session.get([s.state.remote() for s in shards]), 8)
    whole = unique_codes(codes)
    assert np.array_equal(merged.unique, whole.unique) and np.array_equal(merged.counts, whole.counts)
    with pytest.raises(ray_session.exceptions.RayTaskError, match="another partition"):
        ray_session.get(shards[0].add.remote(route_codes(codes, 3)[1]))
