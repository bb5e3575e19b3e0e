"""Ray queries of the renderer: closest hits and shadow (any-hit) tests.

:class:`~vrlab.render.accel.geometry.SceneGeometry` is the front every ray goes through.
Small scenes test every ray against every primitive group at once (``groups``: parallelograms,
triangles, quadrics; ``disks``; ``dense``: the float32 all-pairs kernels); large ones build one
BVH over every primitive (``scene_bvh``, on ``bvh``: binned SAH, per-ray stacks), whose planar
primitives go to Embree where the ``embreex`` wheels exist (``embree``)."""
