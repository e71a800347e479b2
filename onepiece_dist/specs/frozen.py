"""The base of every spec and result model: frozen once validated, and refusing fields it does not know (a
misspelt key is an error that names it, never a silent default)."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict


class Frozen(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")
