"""Fuzz of ``World.load_state`` and ``set_state``: a mutated ``.npz`` state file (or State)
is restored or refused with a tumble error, and a refused one changes nothing.

Seeds: the states of a small model (two jointed bodies, a free body, geoms, an actuator) with
contacts written in, for one world and a batch of two. The seeded mutator corrupts the file's
bytes (truncated, flipped: not a zip, bad CRCs) or rewrites its arrays: fields dropped or
added, other dtypes (strings, bytes, bools, objects, complex), shapes, NaN and inf, counts
out of range, names reordered or renamed, a time that is not a number. No world is stepped.
``TUMBLE_FUZZ_CASES=n`` runs n cases instead of the default.
"""
import numpy as np
import pytest

import tumble

CASES = 500


def make_world(nworld):
    b = tumble.ModelBuilder()
    b.add_body("pelvis", pos=(0, 0, 1), mass=8.0, inertia=(0.1, 0.12, 0.14), angvel=(1, 2, 3))
    b.add_body("thigh", pos=(0, 0.1, 0.7), mass=7.0, inertia=(0.05, 0.05, 0.01))
    b.add_body("ball", pos=(1, 0, 0.2), density=1000.0)
    b.add_geom("pelvis", "box", size=(0.1, 0.1, 0.1))
    b.add_geom("thigh", "capsule", size=(0.05, 0.2))
    b.add_geom("ball", "sphere", size=(0.1,))
    b.add_geom(None, "plane")
    b.add_joint("hip", "ball", "pelvis", "thigh", anchor=(0, 0.1, 0.9), kp=10.0, kd=1.0)
    b.add_joint("root", "free", None, "pelvis")
    return tumble.World(b.build(), dt=1 / 240, nworld=nworld)


def with_contacts(w):
    """The world's state with one contact per world written in (ball on the plane)."""
    st = w.get_state()
    c = w.contact_arrays
    n = 2
    arrays = [np.zeros((w.nworld, n) + a.shape[2:], a.dtype) for a in c]
    geom, body = arrays[0], arrays[1]
    geom[:, 0] = (2, 3)
    body[:, 0] = (w.model.geom_body[2], w.model.geom_body[3])
    arrays[3][:, 0] = (0, 0, 1)                 # normal
    arrays[8][:, 0, 0] = 0.5                    # normal impulse
    st.contacts = type(c)(*arrays)
    st.contact_count = np.ones(w.nworld, np.int64)
    w.set_state(st)
    return w


def snapshot(w):
    st = w.get_state()
    return [st.time] + [np.array(getattr(st, f), copy=True) for f in
                        ("body_pos", "body_quat", "body_vel", "body_angvel", "row_impulse",
                         "applied_force", "pd_target_quat", "contact_count")] + \
        [a.copy() for a in st.contacts]


def same(a, b):
    return len(a) == len(b) and all(
        np.array_equal(x, y, equal_nan=True) if isinstance(x, np.ndarray) else x == y
        for x, y in zip(a, b))


ODD = [lambda a: a.astype(str), lambda a: a.astype(bytes), lambda a: a.astype(bool),
       lambda a: a.astype(complex), lambda a: np.array([a], dtype=object),
       lambda a: a.reshape(-1), lambda a: a[None], lambda a: a[..., :1] if a.ndim else a,
       lambda a: np.array(a.sum()), lambda a: np.full_like(a, np.nan, dtype=float),
       lambda a: np.full_like(a, np.inf, dtype=float), lambda a: np.full_like(a, 2 ** 62),
       lambda a: -np.ones_like(a), lambda a: np.zeros((0,)), lambda a: a.T,
       lambda a: np.array("abc"), lambda a: np.array(["a", "b"]),
       lambda a: np.concatenate([a, a]) if a.ndim else a,
       lambda a: a.astype(np.float32), lambda a: (a + 1e6).astype(a.dtype)]


def mutate_arrays(m, d, names):
    r = m.rng
    for _ in range(r.choice([1, 1, 2, 3])):
        key = m.pick(sorted(d))
        op = r.randrange(6)
        if op == 0:
            del d[key]
            m.descr.append(f"drop {key}")
        elif op == 1:
            d["junk"] = np.arange(3)
            m.descr.append("add junk")
        elif op == 2 and key in ("body_names", "joint_names"):
            v = list(d[key])
            v = v[::-1] if r.random() < 0.5 else v + ["extra"]
            d[key] = np.array(v, dtype=str)
            m.descr.append(f"{key} -> {v}")
        elif op == 3 and key.startswith("contact_"):
            a = d[key].astype(np.int64) if d[key].dtype.kind in "iu" else d[key].copy()
            if a.size:
                a.reshape(-1)[r.randrange(a.size)] = m.pick([-1, 7, 2 ** 31, 10 ** 6, 3])
            d[key] = a
            m.descr.append(f"{key}: an entry out of range")
        elif op == 4 and key in ("time", "format_version", "nrow", "nworld"):
            d[key] = np.array(m.pick(["abc", np.nan, np.inf, [1, 2], True, 3, -1, 2.5]))
            m.descr.append(f"{key} -> {d[key]!r}")
        else:
            k = r.randrange(len(ODD))
            try:
                d[key] = ODD[k](d[key])
            except (ValueError, TypeError, OverflowError):
                continue
            m.descr.append(f"{key}: odd #{k}")
    return d


def test_mutated_state_files_load_or_raise_a_state_error(fuzz, tmp_path):
    worlds = [with_contacts(make_world(1)), with_contacts(make_world(2))]
    seeds = []
    for k, w in enumerate(worlds):
        w.save_state(tmp_path / f"seed{k}.npz")
        seeds.append(dict(np.load(tmp_path / f"seed{k}.npz")))
    raw = [(tmp_path / f"seed{k}.npz").read_bytes() for k in range(2)]

    def case(seed, box):
        m = fuzz.Mutator(seed)
        box["descr"] = m.descr
        r = m.rng
        k = r.randrange(2)
        w = worlds[k] if r.random() < 0.85 else worlds[1 - k]
        path = tmp_path / "case.npz"
        if r.random() < 0.3:
            path.write_bytes(m.raw(raw[k]))
        else:
            d = mutate_arrays(m, {key: v.copy() for key, v in seeds[k].items()},
                              w.model.body_names)
            (np.savez_compressed if r.random() < 0.3 else np.savez)(path, **d)
        m.descr.append(f"into the world with nworld={w.nworld}")
        before = snapshot(w)

        def load():
            try:
                w.load_state(path)
            except tumble.TumbleError:
                assert same(snapshot(w), before), "a refused state changed the world"
                raise
            st = w.get_state()
            for f in ("body_pos", "body_quat", "body_vel", "body_angvel"):
                assert np.all(np.isfinite(getattr(st, f))), f"{f} loaded non-finite"
            w.set_state(worlds_start[id(w)])
        return load

    worlds_start = {id(w): w.get_state() for w in worlds}
    outcomes, escapes, seconds = fuzz.run(fuzz.cases(CASES), case, label="npz state fuzz")
    assert not escapes, (f"{len(escapes)} of {sum(outcomes.values())} mutated state files "
                         f"raised something else than a tumble error:\n" + fuzz.report(escapes))
    assert outcomes.get("ok", 0) > 0 and outcomes.get("StateError", 0) > 0, outcomes


@pytest.mark.parametrize("field,value", [
    ("time", "abc"), ("time", [1.0, 2.0]), ("time", None), ("body_pos", "abc"),
    ("body_pos", [["a", "b", "c"]]), ("body_quat", {"x": 1}), ("row_impulse", object()),
    ("contact_count", "1"), ("contact_count", np.array([1.5])), ("contacts", (1, 2)),
    ("body_names", 5), ("body_names", ("a", "b")), ("joint_names", ["x"])])
def test_odd_state_fields_raise_state_errors(field, value):
    w = with_contacts(make_world(1))
    st = w.get_state()
    before = snapshot(w)
    setattr(st, field, value)
    with pytest.raises(tumble.StateError):
        w.set_state(st)
    assert same(snapshot(w), before)
