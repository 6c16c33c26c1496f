"""One deformer shared by threads: frames on some threads while another moves the rest
mesh, by positions and by offsets, on every backend.

Every frame must equal, bit for bit, the frame of one of the rest states it could have
seen (before or after a move), never a mix, and nothing may crash. The references are
the same deformer's frames taken serially in each state: moves are bit-exact against a
fresh Deformer (test_rest_offsets, test_vulkan_motion), so any difference is a race.
Bounded: a fixed number of frames per thread, and a deadline for the mover.
"""
import threading
import time

import numpy as np
import pytest

import vpffd
from vpffd import edits, shapes
from vpffd._rest_lock import RestLock

from test_vulkan import DEVICE, SEL

BACKENDS = ["serial", "openmp", "vulkan"]


def backend_kwargs(name):
    """Deformer keywords of a backend; skips the test where this build or machine has none."""
    if name == "openmp" and not vpffd._core.has_openmp():
        pytest.skip("no OpenMP in this build")
    if name == "vulkan" and DEVICE is None:
        pytest.skip("no Vulkan backend in this build or no suitable device")
    return dict(backend=name, device=SEL) if name == "vulkan" else dict(backend=name)


def _scene():
    mesh = shapes.icosphere(4)
    mesh = vpffd.Mesh(0.6 * mesh.vertices, mesh.faces)
    lat = vpffd.Lattice((-1, -1, -1), (1, 1, 1), shape=(6, 6, 6), degree=3)
    P = edits.twist(edits.squash(lat.control_points, 0.7), 40)
    return mesh, lat, P


OFFSET = np.array([0.13, -0.21, 0.08])  # crosses cells: the processing order changes


def _frames(d, P, cpu):
    """name -> a function of the deformer returning what one frame kind gives."""
    def kept():
        r = d.deform(P)
        return r.vertices, r.volume, r.rest_volume

    kinds = {
        "kept": kept,
        "plain": lambda: d.deform(P, preserve_volume=False).vertices,
    }
    if cpu:
        kinds.update({
            "ffd": lambda: d.ffd(P),
            "jacobians": lambda: d.jacobians(P),
            "folds": lambda: d.check_folds(P).vertex_min_det,
        })
    return kinds


def _equal(a, b):
    if isinstance(a, tuple):
        return all(_equal(x, y) for x, y in zip(a, b))
    return np.array_equal(np.asarray(a), np.asarray(b))


def _stress(frame_kinds, refs, move, threads=3, frames=12, min_moves=10, deadline_s=60.0):
    """Runs `threads` frame threads against one mover: each makes at least `frames` frames
    and goes on until the mover has made `min_moves` moves (or the deadline passed).
    Returns (mismatches, errors, moves)."""
    names = list(frame_kinds)
    bad, errors = [], []
    end = time.monotonic() + deadline_s
    running = [threads]
    moves = [0]
    lock = threading.Lock()

    def draw(t):
        try:
            i = 0
            while (i < frames or moves[0] < min_moves) and time.monotonic() < end:
                name = names[(t + i) % len(names)]
                got = frame_kinds[name]()
                if not any(_equal(got, r[name]) for r in refs):
                    bad.append(name)
                i += 1
        except BaseException as e:  # noqa: BLE001 (reported by the test)
            errors.append(e)
        finally:
            with lock:
                running[0] -= 1

    def mover():
        try:
            while running[0] > 0:
                move(moves[0] % 2)
                moves[0] += 1
        except BaseException as e:  # noqa: BLE001
            errors.append(e)

    pool = [threading.Thread(target=draw, args=(t,)) for t in range(threads)] + [threading.Thread(target=mover)]
    for t in pool:
        t.start()
    for t in pool:
        t.join(deadline_s + 30)
    assert not any(t.is_alive() for t in pool), "a thread hung"
    return bad, errors, moves[0]


@pytest.mark.parametrize("move_kind", ["positions", "offsets"])
@pytest.mark.parametrize("backend", BACKENDS)
def test_frames_see_one_rest_state(backend, move_kind):
    kw = backend_kwargs(backend)
    mesh, lat, P = _scene()
    d = vpffd.Deformer(mesh, lat, **kw)
    X = [mesh.vertices, mesh.vertices + OFFSET]

    def move(state):
        if move_kind == "offsets":
            d.set_rest_offsets(OFFSET if state else np.zeros(3))
        else:
            d.set_rest_vertices(X[state])

    kinds = _frames(d, P, cpu=backend != "vulkan")
    refs = [None, None]
    for state in (1, 0):  # the stress starts from state 0
        move(state)
        refs[state] = {name: f() for name, f in kinds.items()}
    assert not _equal(refs[0]["kept"], refs[1]["kept"])
    bad, errors, moves = _stress(kinds, refs, move, frames=40 if backend != "vulkan" else 6, min_moves=10)
    assert not errors, errors
    assert not bad, f"{len(bad)} frames matched neither rest state: {sorted(set(bad))}"
    assert moves >= 10
    # The Python side of a move (its rest mesh) agrees with the core afterwards.
    assert any(np.array_equal(d.mesh.vertices, x) for x in X)
    assert np.array_equal(d.mesh.vertices, d._holder.rest_vertices)


@pytest.mark.parametrize("backend", BACKENDS)
def test_multires_frames_from_threads(backend):
    kw = backend_kwargs(backend)
    mesh = shapes.icosphere(4)
    mr = vpffd.Multires(mesh, smoothing=5)
    lat = vpffd.Lattice.around(mesh, shape=(5, 5, 5), degree=3, padding=0.1)
    md = vpffd.MultiresDeformer(mr, lat, **kw)
    P = edits.twist(lat.control_points, 30)
    kinds = {
        "kept": lambda: md.deform(P).vertices,
        "fine": lambda: md.deform(P, volume="fine").vertices,
        "plain": lambda: md.deform(P, preserve_volume=False).vertices,
    }
    ref = {name: f() for name, f in kinds.items()}
    bad, errors, _ = _stress(kinds, [ref], lambda state: time.sleep(0.001), frames=6, min_moves=0)
    assert not errors, errors
    assert not bad, bad


def test_rbf_frames_from_threads():
    mesh = shapes.icosphere(3)
    mr = vpffd.Multires(mesh, smoothing=5)
    H = mesh.vertices[::40]
    rbf = vpffd.RBFDeformer(mr, H)
    T = H + 0.05 * np.sin(3 * H)
    kinds = {"rbf": lambda: rbf.deform(T).vertices}
    ref = {"rbf": kinds["rbf"]()}
    bad, errors, _ = _stress(kinds, [ref], lambda state: time.sleep(0.001), frames=8, min_moves=0)
    assert not errors and not bad


def test_move_inside_a_frame_is_refused():
    lock = RestLock()
    with lock.shared():
        with lock.shared():  # frames may nest
            pass
        with pytest.raises(RuntimeError, match="inside a frame"):
            with lock.exclusive():
                pass
    with lock.exclusive():
        with lock.shared():  # a move may read the rest state
            pass


def test_lock_lets_waiting_frames_in_between_moves():
    """A thread moving back to back does not starve the frames, nor frames the move."""
    lock = RestLock()
    stop = threading.Event()
    frames = [0]

    def mover():
        while not stop.is_set():
            with lock.exclusive():
                time.sleep(0.0005)

    def frame():
        for _ in range(20):
            with lock.shared():
                frames[0] += 1

    m = threading.Thread(target=mover)
    m.start()
    f = threading.Thread(target=frame)
    f.start()
    f.join(20)
    stop.set()
    m.join(20)
    assert frames[0] == 20 and not f.is_alive() and not m.is_alive()
