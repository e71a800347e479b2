"""The key lookup, pure numpy: the method's premise with perfect patches and no network. A held-out grasp whose key
(its voxel code, or any other key of its crop) some train grasp has gets that key's train label: one label per key
(B's, the representative being any grasp of the key) or the key's majority; and held-out grasps ranked by such
lookups from every train label (A), one label per key (B), as many random labels (R) or labels spread over the keys
by count (S). docs/key_study.md measures several keys with it; every study measures its own code
(``StudyResult.lookup``)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from onepiece_dist.core.dedup import unique_codes
from onepiece_dist.stats.ceiling import threshold_ap
from onepiece_dist.stats.selection import one_grasp_per_key
from onepiece_dist.study.result import KeyLookup, LookupRanking


@dataclass(frozen=True)
class Agreement:
    """How often a label agrees with the truth, beside the floor of a label that ignores the shape (independent
    labels at the same positive rates); both None where there was nothing to compare."""

    agreement: float | None = None
    floor: float | None = None


@dataclass(frozen=True)
class LookupTransfer:
    """Held-out grasps labelled by looking their key up among the train grasps' (:func:`lookup_transfer`)."""

    test_grasps: int
    covered: int  # held-out grasps whose key some train grasp has
    coverage: float | None  # their share (None without held-out grasps)
    one_label: Agreement  # one train label of the key (B's)
    majority: Agreement  # the key's majority train label


@dataclass(frozen=True)
class RankedLookup:
    """Held-out grasps ranked by the lookup from some train labels: the mean over ``draws`` seeded draws of the
    labels, their coverage, AP and accuracy, and the spread (sd) of AP and accuracy over the draws."""

    labels: int
    coverage: float
    ap: float
    accuracy: float
    sd_ap: float = 0.0
    sd_accuracy: float = 0.0
    draws: int = 1


def key_ids(train_keys: np.ndarray, test_keys: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """One id per distinct key across both sets: (n,) int64 train ids, (m,) int64 test ids, and how many ids."""
    exact = unique_codes(np.concatenate([train_keys, test_keys]))
    return exact.inverse[:len(train_keys)], exact.inverse[len(train_keys):], len(exact.unique)


def key_labels(ids: np.ndarray, success: np.ndarray, keys: int) -> tuple[np.ndarray, np.ndarray]:
    """Grasps and positive grasps of each key id: ids (n,) int64, success (n,) bool -> (keys,) int64, (keys,)
    float64."""
    counts = np.bincount(ids, minlength=keys)
    return counts, np.bincount(ids, weights=np.asarray(success, dtype=np.float64), minlength=keys)


def lookup_transfer(train_keys: np.ndarray, train_success: np.ndarray, test_keys: np.ndarray,
                    test_success: np.ndarray) -> LookupTransfer:
    """Held-out grasps labelled by a lookup of their key among the train grasps' keys.

    train_keys (n, K) uint8, train_success (n,) bool, test_keys (m, K) uint8, test_success (m,) bool. A covered
    test grasp (its key is some train grasp's) gets the label of one of the key's train grasps ("one_label": B's
    one label per key, its representative being any grasp of the key; the agreement is the expectation over which,
    p_k for a positive test grasp and 1 - p_k for a negative one, p_k the key's positive fraction) or the key's
    majority label, positive where p_k is above one half, as :func:`budget_lookup` scores ("majority"). Each
    agreement comes beside the floor of labels that ignore the shape: p q + (1 - p)(1 - q) for the positive rates
    of the two.
    """
    train, test, keys = key_ids(train_keys, test_keys)
    counts, positives = key_labels(train, train_success, keys)
    covered = counts[test] > 0
    truth = np.asarray(test_success, dtype=bool)[covered]
    share = positives[test[covered]] / np.maximum(counts[test[covered]], 1)  # p_k of each covered test grasp
    one_label = Agreement()
    if covered.any():
        p, q = float(share.mean()), float(truth.mean())
        one_label = Agreement(round(float(np.mean(np.where(truth, share, 1 - share))), 4),
                              round(p * q + (1 - p) * (1 - q), 4))
    return LookupTransfer(test_grasps=int(len(test_keys)), covered=int(covered.sum()),
                          coverage=round(float(covered.mean()), 4) if len(test_keys) else None,
                          one_label=one_label, majority=agreement(share > 0.5, truth))


def agreement(label: np.ndarray, truth: np.ndarray) -> Agreement:
    """Agreement of (n,) bool labels with (n,) bool truth, and the floor of independent labels."""
    if not len(truth):
        return Agreement()
    p, q = float(label.mean()), float(truth.mean())
    return Agreement(round(float(np.mean(label == truth)), 4), round(p * q + (1 - p) * (1 - q), 4))


def decided_share(measure: Agreement, ceiling: float | None) -> float | None:
    """(agreement - floor) / (ceiling - floor): how much of what a label can agree beyond chance the key gives."""
    if measure.agreement is None or ceiling is None or ceiling <= measure.floor:
        return None
    return round((measure.agreement - measure.floor) / (ceiling - measure.floor), 4)


def lookup_scores(train_ids: np.ndarray, train_success: np.ndarray, labelled: np.ndarray, test_ids: np.ndarray,
                  keys: int) -> tuple[np.ndarray, float]:
    """Each test grasp's score: the mean label of the ``labelled`` train grasps (rows, (L,) int64) with its key id
    (:func:`key_ids`, ``keys`` ids in all), or the mean of all labelled grasps where none has it. Returns scores
    (m,) float64 and the covered fraction."""
    success = np.asarray(train_success, dtype=np.float64)[labelled]
    counts, positives = key_labels(train_ids[labelled], success, keys)
    counts, positives = counts[test_ids], positives[test_ids]
    scores = np.where(counts > 0, positives / np.maximum(counts, 1), success.mean() if len(success) else 0.0)
    return scores, float(np.mean(counts > 0)) if len(test_ids) else 0.0


def budget_lookup(train_keys: np.ndarray, train_success: np.ndarray, test_keys: np.ndarray,
                  test_success: np.ndarray, seed: int, draws: int = 5) -> dict[str, RankedLookup]:
    """B against R without a network: held-out grasps ranked by :func:`lookup_scores` from (A) every train label,
    (B) one label per key, of a grasp of the key drawn at random, (R) as many labels as B of train grasps drawn at
    random, (S) as many labels spread over the keys by count (:func:`grasps_by_key_count`); B, R and S over ``draws``
    seeded draws (mean and spread). AP over held-out grasps; accuracy at a score above one half."""
    truth = np.asarray(test_success, dtype=bool)
    inverse = unique_codes(train_keys).inverse  # the draws group train grasps by key
    keys = int(inverse.max()) + 1 if len(inverse) else 0
    train_ids, test_ids, ids = key_ids(train_keys, test_keys)  # the scores look keys up across both sets

    def measure(labelled: np.ndarray) -> RankedLookup:
        scores, covered = lookup_scores(train_ids, train_success, labelled, test_ids, ids)
        accuracy = float(np.mean((scores > 0.5) == truth))
        return RankedLookup(labels=int(len(labelled)), coverage=round(covered, 4),
                            ap=round(threshold_ap(scores, truth), 4), accuracy=round(accuracy, 4))

    def summary(runs: list[RankedLookup]) -> RankedLookup:
        def mean(values) -> float:
            return round(float(np.mean(values)), 4)

        def sd(values) -> float:
            return round(float(np.std(values)), 4)

        ap, accuracy = [r.ap for r in runs], [r.accuracy for r in runs]
        return RankedLookup(labels=int(round(np.mean([r.labels for r in runs]))),
                            coverage=mean([r.coverage for r in runs]), ap=mean(ap), accuracy=mean(accuracy),
                            sd_ap=sd(ap), sd_accuracy=sd(accuracy), draws=draws)

    rng = np.random.default_rng([seed, 29])
    one_per_key = [measure(one_grasp_per_key(inverse, rng)) for _ in range(draws)]
    random = [measure(rng.permutation(len(train_keys))[:keys]) for _ in range(draws)]
    stratified = [measure(grasps_by_key_count(inverse, keys, rng)) for _ in range(draws)]
    return {"A": measure(np.arange(len(train_keys))), "B": summary(one_per_key), "R": summary(random),
            "S": summary(stratified)}


def grasps_by_key_count(inverse: np.ndarray, budget: int, rng: np.random.Generator, power: float = 0.5) -> np.ndarray:
    """``budget`` rows spread over the keys in proportion to count ** power (largest remainders; a key gives at most
    its own rows, so a little of the budget can go unspent), drawn at random within each key: inverse (n,) int64 key
    of each row -> (<= budget,) int64 rows. Labels go where the grasps are, several on a frequent key."""
    counts = np.bincount(inverse)
    weight = counts.astype(np.float64) ** power
    quota = budget * weight / weight.sum()
    take = np.floor(quota).astype(np.int64)
    take[np.argsort(take - quota, kind="stable")[:budget - int(take.sum())]] += 1
    take = np.minimum(take, counts)
    order = rng.permutation(len(inverse))
    grouped = order[np.argsort(inverse[order], kind="stable")]  # shuffled rows, key by key
    starts = np.r_[0, np.cumsum(counts)[:-1]]
    rank = np.arange(len(inverse)) - np.repeat(starts, counts)  # place of each grouped row within its key
    return grouped[rank < np.repeat(take, counts)]




def key_lookup(train_codes: np.ndarray, train_success: np.ndarray, test_codes: np.ndarray,
               test_success: np.ndarray, seed: int) -> KeyLookup:
    """A study's own code as a lookup: train_codes (n, K) uint8 and (n,) labels of A, test_codes (m, K) uint8 and
    (m,) labels of the held-out grasps."""
    train_success, test_success = np.asarray(train_success, bool), np.asarray(test_success, bool)
    transfer = lookup_transfer(train_codes, train_success, test_codes, test_success)
    ranked = budget_lookup(train_codes, train_success, test_codes, test_success, seed)
    return KeyLookup(train_codes=len(unique_codes(train_codes).unique), coverage=transfer.coverage or 0.0,
                     one_label=transfer.one_label.agreement, one_label_floor=transfer.one_label.floor,
                     majority=transfer.majority.agreement, majority_floor=transfer.majority.floor,
                     ranked={arm: LookupRanking(labels=r.labels, coverage=r.coverage, ap=r.ap, accuracy=r.accuracy)
                             for arm, r in ranked.items()})
