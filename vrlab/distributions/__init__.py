"""Warps from uniforms to domains, each with its pdf; discrete sampling."""
from .base import Distribution
from .frames import Oriented, orthonormal_basis, to_local, to_world

__all__ = ["Distribution", "Oriented", "orthonormal_basis", "to_local", "to_world"]
