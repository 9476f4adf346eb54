"""Separation certificates: found where boxes overlap but objects are apart, always
verified, and never wrong (manifold3d finds zero intersection volume)."""

from xml.etree import ElementTree

import manifold3d
import numpy as np
import trimesh
from scipy.spatial.transform import Rotation

from cadpipe import CollisionWorld, Mesh, Pipe
from cadpipe.collision import Sphere
from cadpipe.collision.certificate import Certificate, verify


def placed(t, rot=None):
    m = np.eye(4)
    m[:3, 3] = t
    if rot is not None:
        m[:3, :3] = rot
    return m


def torus():
    return Mesh.from_trimesh(trimesh.creation.torus(1.0, 0.3, major_sections=24,
                                                    minor_sections=12))


def c_shape():
    solid = manifold3d.Manifold.cube((4.0, 4.0, 1.0)) - manifold3d.Manifold.cube(
        (3.0, 2.0, 1.2)).translate((1.0, 1.0, -0.1))
    return Mesh.from_manifold(solid)


def test_spheres_whose_boxes_overlap_get_the_straight_cut():
    world = CollisionWorld()
    world.add("a", Sphere(1.0))
    world.add("b", Sphere(1.0), transform=placed((1.6, 1.6, 0.0)))
    cert = world.separate("a", "b")
    assert cert.kind == "segment" and cert.axes == (0, 1)
    np.testing.assert_allclose(sorted(map(tuple, cert.chain)), [(0.6, 1.0), (1.0, 0.6)])
    assert cert.verify()


def test_disjoint_boxes_and_empty_overlaps():
    world = CollisionWorld()
    world.add("c", c_shape())
    world.add("far", Sphere(0.3), transform=placed((9, 0, 0)))
    world.add("bar", Mesh.from_trimesh(trimesh.creation.box(extents=(2.5, 0.8, 0.6))),
              transform=placed((3.0, 2.0, 0.5)))
    assert world.separate("c", "far").kind == "boxes"
    cert = world.separate("c", "bar")             # the bar sits in the C's mouth
    assert cert.kind == "empty" and cert.verify()


def collect(shape_a, shape_b, seed, count, spread):
    """Certificates of random apart poses whose boxes overlap, with the volume check."""
    rng = np.random.default_rng(seed)
    world = CollisionWorld()
    world.add("a", shape_a)
    world.add("b", shape_b)
    solid_a, solid_b = shape_a.to_manifold(), shape_b.to_manifold()
    kinds = []
    while len(kinds) < count:
        pose = placed(rng.uniform(-spread, spread, 3) * (1, 1, 0.4),
                      Rotation.random(random_state=rng).as_matrix())
        world.set_pose("b", pose)
        pair = world.check().pairs[0]
        if pair.colliding or pair.decided_by == "aabb":
            continue
        cert = world.separate("a", "b")
        if cert is not None and cert.kind == "boxes":
            continue          # the exact boxes are apart (the broad phase's are looser)
        kinds.append(None if cert is None else cert.kind)
        if cert is not None:
            assert cert.verify() and verify(cert) == (True, "chain separates the objects") \
                or cert.kind in ("empty", "segment")
            assert (solid_a ^ solid_b.transform(pose[:3])).volume() == 0
    return kinds


def test_every_certificate_verifies_and_is_right():
    kinds = collect(torus(), torus(), 3, 150, 3.0) + collect(c_shape(), torus(), 5, 60, 4.0)
    found = [k for k in kinds if k is not None]
    assert len(found) >= 0.7 * len(kinds)
    assert {"segment", "chain", "empty"} <= set(found)


def chain_case():
    world = CollisionWorld()
    world.add("a", torus())
    world.add("b", torus())
    rng = np.random.default_rng(3)
    while True:
        pose = placed(rng.uniform(-3, 3, 3) * (1, 1, 0.4),
                      Rotation.random(random_state=rng).as_matrix())
        world.set_pose("b", pose)
        pair = world.check().pairs[0]
        if not pair.colliding and pair.decided_by == "fcl":
            cert = world.separate("a", "b")
            if cert is not None and cert.kind == "chain":
                return world, cert


def test_the_verifier_rejects_broken_certificates():
    _, cert = chain_case()
    assert len(cert.chain) > 2 and cert.verify()
    fields = dict(cert.__dict__)
    same_side = Certificate(**{**fields, "regions": (cert.regions[0], cert.regions[0])})
    assert verify(same_side) == (False, "an object reaches the other object's side")
    through = Certificate(**{**fields, "chain": np.array([cert.chain[0], cert.regions[0][0][0],
                                                          cert.chain[-1]])})
    assert not through.verify()
    outside = Certificate(**{**fields, "chain": cert.chain + 10.0})
    assert verify(outside) == (False, "chain leaves R")
    loop = np.vstack([cert.chain[:1], cert.chain[-1:], cert.chain[:1], cert.chain[-1:]])
    assert not Certificate(**{**fields, "chain": loop}).verify()


def test_the_verifier_uses_none_of_the_search_code():
    import inspect

    from cadpipe.collision import certificate

    used = set(inspect.getclosurevars(certificate.verify).globals)
    for helper in ("_even_odd", "_outward"):
        used |= set(inspect.getclosurevars(getattr(certificate, helper)).globals)
    assert used <= {"np", "_even_odd", "_outward"}


def test_check_can_decide_pairs_by_certificate():
    world, _ = chain_case()
    report = world.check(certify=True)
    assert report.pairs[0].decided_by == "certificate"
    assert report.pairs[0].certificate.verify()
    assert world.check().pairs[0].decided_by == "fcl"


def test_pipes_get_certificates_too():
    world = CollisionWorld()
    world.add("a", Pipe([[0, 0, 0], [1, 1, 0.1], [2, 2, 0]], 0.3, caps="round"))
    world.add("b", Pipe([[1.4, 0.2, 0], [2.4, 1.2, 0]], 0.2, caps="round"))
    assert not world.check().collisions
    cert = world.separate("a", "b")
    assert cert is not None and cert.kind in ("segment", "chain") and cert.verify()


def test_certificates_draw_as_svg(tmp_path):
    _, cert = chain_case()
    svg = cert.to_svg()
    root = ElementTree.fromstring(svg)
    tags = [el.tag.split("}")[1] for el in root.iter()]
    assert tags.count("path") == 2 and "polyline" in tags
    written = cert.save_svg(tmp_path / "cert.svg")
    assert written.read_text() == svg
    assert list(tmp_path.iterdir()) == [written]
