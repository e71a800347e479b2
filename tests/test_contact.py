"""Contact keys (core/contact.py): the relief under each pad, from tiny synthetic crops in the gripper frame."""

import numpy as np
import pytest

from onepiece_dist.core.contact import EMPTY_CROP, ContactKeySpec, canonical_keys, contact_keys, turned_keys
from onepiece_dist.core.voxel import voxel_indices

REGION = (0.04, 0.08, 0.02)  # the default closing region: depth, width, height (m)
SPEC = ContactKeySpec(REGION)  # 10 mm cells: 4 x 2 per pad, 2 mm relief steps, 4 levels, 5 mm opening steps


def face(v_at_palm: float, slope: float = 0.0, n: int = 40) -> np.ndarray:
    """(n*n, 3) points of a face across the whole pad, at v = v_at_palm + slope * u."""
    u, t = np.meshgrid(np.linspace(0, REGION[0], n, endpoint=False), np.linspace(-0.01, 0.01, n, endpoint=False))
    u, t = u.ravel(), t.ravel()
    return np.stack([u, v_at_palm + slope * u, t], axis=1)


def slab(thickness: float, centre: float = 0.0, slope: float = 0.0) -> np.ndarray:
    """Both faces of a slab between the pads: one at centre - thickness/2 (tilted by ``slope``), one at + ."""
    return np.concatenate([face(centre - thickness / 2, slope), face(centre + thickness / 2)])


def keys_of(*crops: np.ndarray, spec: ContactKeySpec = SPEC) -> np.ndarray:
    rows = np.concatenate([np.full(len(c), k) for k, c in enumerate(crops)])
    return contact_keys(rows, np.concatenate(crops), len(crops), spec)


def occupied_voxels(points: np.ndarray) -> set[int]:
    return set(voxel_indices(points, (4, 8, 2), 0.01).tolist()) - {-1}


def test_a_slab_square_to_the_closing_axis_meets_both_pads_flat_and_gives_its_thickness_as_the_opening():
    key = keys_of(slab(0.03))[0]
    assert key.shape == (SPEC.key_bytes,) == (17,)
    assert np.all(key[:16] == 0)
    assert key[16] == 6  # 30 mm / 5 mm


def test_the_key_keeps_the_relief_wherever_the_object_sits_between_the_pads():
    centred, shifted = keys_of(slab(0.03), slab(0.03, centre=0.007))
    assert np.array_equal(centred, shifted)


def test_a_face_tilted_by_ten_degrees_fills_the_same_voxels_as_a_square_one_but_gets_another_key():
    slope = np.tan(np.radians(10))
    square, tilted = slab(0.039), slab(0.039, slope=slope)
    assert occupied_voxels(square) == occupied_voxels(tilted)
    key_square, key_tilted = keys_of(square, tilted)
    assert not np.array_equal(key_square, key_tilted)
    pad0 = key_tilted[:8].reshape(4, 2)  # (u cells, t cells) of the tilted face's pad
    # relief at each u cell's nearest point: i * 10 mm * tan(10 deg) = 0, 1.76, 3.53, 5.29 mm -> 2 mm levels
    assert pad0[:, 0].tolist() == pad0[:, 1].tolist() == [0, 0, 1, 2]
    assert np.all(key_tilted[8:16] == 0)  # the other face is square


def test_cells_the_crop_does_not_reach_are_marked_empty_and_an_empty_crop_has_no_opening():
    point = np.array([[0.005, -0.01, -0.005]])  # one point, in pad cell (0, 0) of both pads
    key, empty = keys_of(point, np.zeros((0, 3)))
    assert key[0] == 0 and np.all(key[1:8] == SPEC.levels)
    assert key[8] == 0 and np.all(key[9:16] == SPEC.levels)
    assert key[16] == 0  # both pads first meet the same point: no opening left
    assert np.all(empty[:16] == SPEC.levels) and empty[16] == EMPTY_CROP


def test_relief_beyond_the_last_level_is_one_level_and_the_opening_saturates_below_the_empty_mark():
    spec = ContactKeySpec(REGION, step=0.001, levels=2, width_step=0.0001)
    key = keys_of(slab(0.039, slope=np.tan(np.radians(10))), spec=spec)[0]
    assert key[:8].max() == 1
    assert key[16] == EMPTY_CROP - 1


def test_crops_keyed_together_get_the_keys_they_get_one_by_one():
    crops = [slab(0.03), slab(0.02, slope=0.3), np.array([[0.03, 0.01, 0.009]])]
    together = keys_of(*crops)
    for k, crop in enumerate(crops):
        assert np.array_equal(together[k], keys_of(crop)[0])


def test_turning_the_crop_about_the_approach_axis_turns_its_key_and_leaves_its_canonical_key():
    rng = np.random.default_rng(3)
    crop = rng.uniform([0, -0.04, -0.01], [0.04, 0.04, 0.01], size=(60, 3))
    turned_crop = crop * np.array([1.0, -1.0, -1.0])
    turned_crop[:, 2] = np.minimum(turned_crop[:, 2], np.nextafter(0.01, 0))  # t = 0.01 lies outside the region
    key, key_of_turned = keys_of(crop, turned_crop)
    assert not np.array_equal(key, key_of_turned)
    assert np.array_equal(turned_keys(key[None], SPEC)[0], key_of_turned)
    assert np.array_equal(canonical_keys(key[None], SPEC), canonical_keys(key_of_turned[None], SPEC))


@pytest.mark.parametrize("kwargs, named", [({"cell": 0.015}, "cell=0.015"), ({"levels": 0}, "levels=0"),
                                           ({"step": 0.0}, "step=0.0")])
def test_a_key_spec_that_cannot_quantize_the_region_is_refused_naming_the_value(kwargs, named):
    with pytest.raises(ValueError, match=named):
        ContactKeySpec(REGION, **kwargs)


def test_points_and_their_crop_rows_must_be_as_many():
    with pytest.raises(ValueError, match="rows has 2 entries for 3 points"):
        contact_keys(np.zeros(2, dtype=np.int64), np.zeros((3, 3)), 1, SPEC)
