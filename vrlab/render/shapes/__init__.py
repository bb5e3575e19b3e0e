"""Shape elements, one module per Mitsuba 3 plugin (``rectangle``, ``disk``, ``sphere``,
``cube``, ``obj``, ...) and vrlab's ``ellipsoid``; the base class :class:`Shape` and the
primitive parts the ray tracer intersects live in :mod:`.base`."""
from .base import CustomPart, DiskPart, Parallelograms, Quadric, Shape, Triangles
from .cube import Cube
from .cylinder import Cylinder
from .disk import Disk
from .ellipsoid import Ellipsoid
from .instance import Instance
from .mesh import Mesh
from .obj import OBJMesh
from .ply import PLYMesh
from .rectangle import Rectangle
from .serialized import SerializedMesh
from .shapegroup import ShapeGroup
from .sphere import Sphere

__all__ = ["Cube", "CustomPart", "Cylinder", "Disk", "DiskPart", "Ellipsoid", "Instance", "Mesh", "OBJMesh", "PLYMesh", "Parallelograms", "Quadric",
           "Rectangle", "SerializedMesh", "Shape", "ShapeGroup", "Sphere", "Triangles"]
