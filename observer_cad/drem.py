"""Compatibility alias: model files written for observer_cad 0.1 import
``from observer_cad.drem import DremSpec``; new model files use
``from observer_cad import DremSpec``. Everything here lives in :mod:`observer_cad.observers`."""
from .observers import DremSpec

__all__ = ["DremSpec"]
