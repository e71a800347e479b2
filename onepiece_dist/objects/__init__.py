"""Object sources and safe loading: every mesh is parsed, checked and sanitized here before any
simulator sees it. Depends on ``core`` only."""

from onepiece_dist.objects.loading import LoadedObject, load_object
from onepiece_dist.objects.sources import ObjectRef, resolve_source

__all__ = ["LoadedObject", "ObjectRef", "load_object", "resolve_source"]
