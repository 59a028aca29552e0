"""Hypothesis strategies: random machine models (rigid trees, closed loops, loops through
ground, virtual bodies, beams) as model dictionaries for ``model_from_dict``."""

import numpy as np
from hypothesis import strategies as st

INF = float("inf")


def _rotation(rng) -> np.ndarray:
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.diag(r))


def rigid_body(rng, name: str) -> dict:
    """A box-like rigid body: its inertia satisfies the triangle inequality by construction."""
    mass = float(10 ** rng.uniform(0, 3))
    a, b, c = rng.uniform(0.1, 1.0, 3)
    principal = mass / 12 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])
    rot = _rotation(rng)
    inertia = rot @ np.diag(principal) @ rot.T
    inertia = 0.5 * (inertia + inertia.T)
    return {
        "name": name,
        "kind": "rigid",
        "mass": mass,
        "center_of_mass": rng.uniform(-1, 1, 3).tolist(),
        "inertia": inertia.tolist(),
    }


def hinge(rng, name: str, a: str, b: str, at, special: bool) -> dict:
    """Elastic hinge; with ``special`` some directions are released (0) or rigid (inf)."""
    k = 10 ** rng.uniform(5, 7, 3)
    kr = 10 ** rng.uniform(4, 6, 3)
    six = np.r_[k, kr].astype(object)
    if special:
        for i in rng.choice(6, size=rng.integers(1, 3), replace=False):
            six[i] = 0.0 if rng.random() < 0.5 else INF
    return {
        "name": name,
        "between": [a, b],
        "at": list(map(float, at)),
        "stiffness": [float(x) for x in six[:3]],
        "rotational_stiffness": [float(x) for x in six[3:]],
    }


def random_model(
    seed: int,
    n_bodies: int,
    n_loops: int,
    ground_loops: int,
    special: bool = False,
    virtual: bool = False,
) -> dict:
    """Tree of rigid bodies grown from ground plus extra hinges closing loops."""
    rng = np.random.default_rng(seed)
    names = [f"b{i}" for i in range(n_bodies)]
    bodies = [rigid_body(rng, n) for n in names]
    hinges = []
    for i, n in enumerate(names):
        parent = "ground" if i == 0 else names[rng.integers(0, i)]
        hinges.append(hinge(rng, f"t{i}", parent, n, rng.uniform(-1, 1, 3), False))
    for j in range(n_loops if n_bodies > 1 else 0):
        a, b = rng.choice(n_bodies, 2, replace=False)
        hinges.append(hinge(rng, f"l{j}", names[a], names[b], rng.uniform(-1, 1, 3), special))
    for j in range(ground_loops):
        b = names[rng.integers(0, n_bodies)]
        hinges.append(hinge(rng, f"g{j}", "ground", b, rng.uniform(-1, 1, 3), special))
    if virtual:  # a massless joint between the last body and ground, springs on both sides
        p = rng.uniform(-1, 1, 3)
        bodies.append({"name": "v", "kind": "virtual"})
        hinges.append(hinge(rng, "v1", names[-1], "v", p, False))
        hinges.append(hinge(rng, "v2", "v", "ground", p, False))
    return {"name": f"random-{seed}", "body": bodies, "hinge": hinges}


@st.composite
def rigid_models(draw, special=False):
    """Random rigid models: 1-5 bodies, 0-3 loops, 0-2 loops through ground."""
    return random_model(
        draw(st.integers(0, 2**31 - 1)),
        draw(st.integers(1, 5)),
        draw(st.integers(0, 3)),
        draw(st.integers(0, 2)),
        special=special,
        virtual=draw(st.booleans()),
    )
