"""What training measures, as typed records (no torch: a job's status and the CLI read them where nothing trains).

:class:`Validation` is a network scored on a validation split; :class:`EpochMetrics` one epoch of the train stage
(flat, as the dataset's ``training`` attribute and the ``train/`` arrays name them); :class:`CurvePoint` one
evaluation of a run with a budget in gradient steps."""

from __future__ import annotations

from dataclasses import dataclass, fields


@dataclass(frozen=True)
class Validation:
    """The network on a validation split: mean binary cross-entropy, accuracy at one half, average precision and
    the share of positive labels."""

    loss: float
    accuracy: float
    ap: float
    positives: float

    def rounded(self, digits: int) -> Validation:
        return Validation(*(round(getattr(self, f.name), digits) for f in fields(self)))


@dataclass(frozen=True)
class EpochMetrics:
    """One epoch of the train stage: its mean training loss and the validation figures after it."""

    epoch: int
    train_loss: float
    val_loss: float
    val_accuracy: float
    val_ap: float
    val_positives: float

    @classmethod
    def after(cls, epoch: int, train_loss: float, validation: Validation) -> EpochMetrics:
        return cls(epoch, train_loss, validation.loss, validation.accuracy, validation.ap, validation.positives)

    @classmethod
    def from_json(cls, values: dict) -> EpochMetrics:
        return cls(**{f.name: values[f.name] for f in fields(cls)})

    def to_json(self) -> dict[str, float | int]:
        return {f.name: getattr(self, f.name) for f in fields(self)}


@dataclass(frozen=True)
class CurvePoint:
    """One evaluation of a run with a budget in gradient steps: after ``step`` steps, ``validation`` (rounded)."""

    step: int
    validation: Validation

    def to_json(self) -> dict[str, float | int]:
        """Flat, as a study's stored runs keep it: step, val_loss, val_accuracy, val_ap, val_positives."""
        return {"step": self.step, **{f"val_{f.name}": getattr(self.validation, f.name)
                                      for f in fields(self.validation)}}

    @classmethod
    def from_json(cls, values: dict) -> CurvePoint:
        return cls(values["step"], Validation(*(values[f"val_{f.name}"] for f in fields(Validation))))
