"""Warps from uniforms to domains, each with its pdf; discrete sampling.

Every distribution has ``dim_u``, ``sample(u)``, ``pdf(x)``, a ``measure`` and,
where the warp is a bijection, ``invert(x)``.
"""
from .._lazy import lazy_attributes
from .base import Distribution
from .discrete import AliasTable, CDFTable
from .frames import Frame, Oriented, orthonormal_basis, to_local, to_world
from .light_bvh import LightBVH
from .interval import Exponential, LinearInterval, Product, TruncatedNormal, UniformBox, UniformInterval
from .mixture import Mixture
from .point_masses import OffAtoms, PointMasses, atom_mass
from .planar import Disk, Rectangle, Triangle, concentric_disk
from .microfacet import GGX
from .spherical import CosineHemisphere, PhongLobe, UniformCone, UniformHemisphere, UniformSphere
from .solid_angle import LightSample, SolidAngleFromArea, SphereCone
from .quadrics import EllipsoidSurface, SphereSurface, unit_sphere_hit, unit_sphere_hits, unit_sphere_roots
from .surfaces import BoxSurface, DiskSurface, RectangleSurface, Surface
from .tabulated import PiecewiseConstant1D, PiecewiseConstant2D

__all__ = [
    "AliasTable", "CDFTable", "Distribution", "Frame", "Oriented", "orthonormal_basis", "to_local", "to_world",
    "Exponential", "LinearInterval", "Product", "TruncatedNormal", "UniformBox", "UniformInterval",
    "LightBVH", "Mixture", "OffAtoms", "PointMasses", "atom_mass", "Disk", "Rectangle", "Triangle", "concentric_disk",
    "GGX", "CosineHemisphere", "PhongLobe", "UniformCone", "UniformHemisphere", "UniformSphere",
    "PiecewiseConstant1D", "PiecewiseConstant2D",
    "LightSample", "SolidAngleFromArea", "SphereCone",
    "BoxSurface", "CylinderSurface", "DiskSurface", "EllipsoidSurface", "RectangleSurface", "SphereSurface", "Surface",
    "unit_sphere_hit", "unit_sphere_hits", "unit_sphere_roots",
    "MeshLightSample", "SphericalTriangle", "TriangleMeshSolidAngle", "TriangleMeshSurface", "triangle_solid_angle",
    "EnvironmentMap", "latlong_direction", "latlong_uv", "BilinearPiecewise2D", "DeltaDirection", "LobeMixture",
    "Beckmann", "MicrofacetNormals", "VisibleNormals",
    "FILTERS", "BoxFilter", "FilterWindow", "GaussianFilter", "ReconstructionFilter", "TentFilter",
]

# the warps of the renderer's scene elements are imported on first use (start-up time)
__getattr__, __dir__ = lazy_attributes(__name__, {
    **{n: "filters" for n in ("FILTERS", "BoxFilter", "FilterWindow", "GaussianFilter", "ReconstructionFilter",
                              "TentFilter")},
    "Beckmann": "microfacet", "MicrofacetNormals": "microfacet", "VisibleNormals": "visible_normals",
    "CylinderSurface": "cylinder",
    **{n: "triangles" for n in ("SphericalTriangle", "triangle_solid_angle")},
    **{n: "mesh_light" for n in ("MeshLightSample", "TriangleMeshSolidAngle", "TriangleMeshSurface")},
    **{n: "envmap" for n in ("EnvironmentMap", "latlong_direction", "latlong_uv")},
    "BilinearPiecewise2D": "bilinear", "DeltaDirection": "lobes", "LobeMixture": "lobes"}, __all__)
