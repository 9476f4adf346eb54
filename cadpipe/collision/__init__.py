"""Collision checks for robot cells (source 2): self-collision first, then a
bounding-volume broad phase, an exact narrow phase and separation certificates.

Meshes go through FCL's BVHs (plus a containment test FCL lacks); pipes are
checked analytically as chains of round cones; robots come from URDF.
"""

from cadpipe.collision.bodies import Box, Capsule, Sphere, Surface
from cadpipe.collision.certificate import Certificate
from cadpipe.collision.fixture import PipeContainment
from cadpipe.collision.robot import Joint, Robot, srdf_disabled_pairs
from cadpipe.collision.reports import (STAGES, Clearance, CollisionReport, CollisionReports,
                                       PairResult)
from cadpipe.collision.world import CollisionWorld

__all__ = ["STAGES", "Box", "Capsule", "Certificate", "Clearance", "CollisionReport",
           "CollisionReports", "CollisionWorld", "Joint", "PairResult", "PipeContainment",
           "Robot", "Sphere", "Surface", "srdf_disabled_pairs"]
