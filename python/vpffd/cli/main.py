"""The ``vpffd`` command: ``vpffd demo | deform | subdiv | info | bench | devices`` (``vpffd CMD --help``).

Errors end the command with one line on stderr, ``vpffd CMD: error: ...``, and
exit status 2 for bad arguments or 1 for anything else (bad or missing files,
a correction that does not exist). ``VPFFD_TRACEBACK=1`` shows the traceback.
"""
from __future__ import annotations

import argparse
import logging
import os
import re
import sys
import time
import warnings

from .progress import Progress

EXIT_ERROR, EXIT_USAGE = 1, 2


class _Formatter(argparse.ArgumentDefaultsHelpFormatter):
    """Shows defaults, except empty ones and those the help already states."""

    def _get_help_string(self, action):
        h = action.help or ""
        if action.default in (None, False) or "default" in h:
            return h
        return super()._get_help_string(action)


class _UsageError(Exception):
    """Bad command-line value found after parsing (exit status 2)."""


class _Parser(argparse.ArgumentParser):
    """argparse with a one-line error (argparse prints the usage first)."""

    def error(self, message):
        sys.stderr.write(f"{self.prog}: error: {message} (see '{self.prog} --help')\n")
        sys.exit(EXIT_USAGE)


# --- argument types ---------------------------------------------------------------
def _lattice_shape(text: str):
    parts = re.split(r"[x,]", text.strip().lower())
    try:
        n = [int(p) for p in parts]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected NxNxN such as 8x8x8 (or one number), got {text!r}") from None
    if len(n) == 1:
        n = n * 3
    if len(n) != 3 or min(n) < 2 or max(n) > 64:
        raise argparse.ArgumentTypeError(f"expected three sizes 2..64 such as 8x8x8, got {text!r}")
    return tuple(n)


def _size(text: str):
    m = re.fullmatch(r"\s*(\d+)\s*[x,]\s*(\d+)\s*", text)
    if not m or not (8 <= int(m.group(1)) <= 8192 and 8 <= int(m.group(2)) <= 8192):
        raise argparse.ArgumentTypeError(f"expected WIDTHxHEIGHT in pixels such as 320x240, got {text!r}")
    return int(m.group(1)), int(m.group(2))


def _vec3(text: str, what: str):
    parts = text.split(",")
    try:
        v = [float(p) for p in parts]
    except ValueError:
        v = []
    if len(v) != 3 or not all(abs(x) < float("inf") for x in v):
        raise argparse.ArgumentTypeError(f"{what}: expected three numbers X,Y,Z, got {text!r}")
    return v


def _drag(text: str):
    if text.count(":") != 1:
        raise argparse.ArgumentTypeError(f"expected X,Y,Z:TX,TY,TZ (a rest point and its target), got {text!r}")
    a, b = text.split(":")
    return _vec3(a, "--drag point"), _vec3(b, "--drag target")


def _view(text: str):
    from ..views import parse_view
    try:
        return parse_view(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e).replace("view: ", "")) from None


def _finite(text: str):
    try:
        x = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not abs(x) < float("inf"):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return x


def _positive(text: str):
    x = _finite(text)
    if x <= 0:
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}")
    return x


def _positive_int(text: str):
    try:
        n = int(text)
    except ValueError:
        n = 0
    if n < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}")
    return n


# --- mesh files and pictures (vpffd.io and vpffd.render raise BackendUnavailableError
# when the build lacks OpenMesh or Embree) ---------------------------------------------
def _extension(path: str) -> str:
    name = os.path.basename(path).lower()
    return name.rsplit(".", 1)[-1] if "." in name else ""


def _load(path: str):
    if not os.path.exists(path):
        raise FileNotFoundError(2, "no such file", path)
    if os.path.isdir(path):
        raise IsADirectoryError(21, "is a folder, not a mesh file", path)
    from ..io import load_mesh
    return load_mesh(path)


def _render_png(path, deformer, result, size, up, lattice_style, view=None):
    from .. import render_comparison, save_png  # rest | plain FFD | volume-preserved
    save_png(path, render_comparison(deformer, result, size=size, up=up, lattice_style=lattice_style, view=view))


# --- commands ---------------------------------------------------------------------
def _cmd_demo(args) -> int:
    from .demo import run_demo
    run_demo(out=args.out, quick=args.quick, render=not args.no_render, size=args.size, progress=Progress)
    return 0


def _check_lattice(args) -> None:
    if args.degree < 1 or args.degree > 5:
        raise _UsageError(f"--degree: expected 1..5, got {args.degree}")
    if min(args.lattice) < args.degree + 1:
        raise _UsageError(f"--lattice {'x'.join(map(str, args.lattice))} is too small for degree {args.degree} "
                          f"(need at least {args.degree + 1} per axis)")


def _default_toward(args) -> None:
    if args.toward is None:  # the first other axis: "--axis x --bend 30" just works
        args.toward = "y" if args.axis == "x" else "x"
    if args.bend is not None and args.toward == args.axis:
        raise _UsageError(f"--bend: --toward {args.toward} must differ from --axis {args.axis} (the axis that bends)")


def _same_file(a, b) -> bool:
    """Whether paths a and b name one file (links and other spellings included)."""
    try:
        return os.path.samefile(a, b)
    except OSError:  # b does not exist yet (or a cannot be read: load_mesh says so)
        return False


def _cmd_deform(args) -> int:
    if args.squash is not None and args.squash <= 0:
        raise _UsageError(f"--squash: expected a positive factor, got {args.squash}")
    if args.taper is not None and args.taper < 0:
        raise _UsageError(f"--taper: expected a factor >= 0, got {args.taper}")
    _check_lattice(args)
    if args.padding < 0:
        raise _UsageError(f"--padding: expected a margin >= 0, got {args.padding}")
    if args.axis is None and args.up is not None:  # edits follow the model's up axis
        args.axis = args.up
    if args.axis is not None:
        _default_toward(args)
    if args.multires is not None and not args.multires > 0:
        raise _UsageError(f"--multires: expected a positive smoothing, got {args.multires}")
    _check_outputs(args, (1600, 600))

    # stages: read, embed, deform, write (the bar shows only past one second)
    bar = Progress("deform", 4)
    try:
        return _deform(args, bar)
    finally:
        bar.close()


def _deform(args, bar) -> int:
    import numpy as np

    from .. import edits
    from ..deformer import Deformer
    from ..lattice import Lattice
    from ..mesh import Mesh

    mesh = _load(args.input)
    up_note = ""
    if args.up is None:
        from ..views import guess_up_axis  # the pictures' and Python's rule (the file's name is on the mesh)
        args.up, why = guess_up_axis(mesh)
        up_note = f"up axis {args.up} (guessed: {why}; --up to change)"
        if args.axis is None:
            args.axis = args.up
            _default_toward(args)
    bar(1, 4, "embedding")
    lat = Lattice.around(mesh, shape=args.lattice, degree=args.degree, padding=args.padding)
    P = np.array(lat.rest_points)
    done = []
    if args.squash is not None:
        P = edits.squash(P, args.squash, axis=args.axis)
        done.append(f"squash {args.squash:g} along {args.axis}")
    if args.taper is not None:
        P = edits.taper(P, args.taper, axis=args.axis)
        done.append(f"taper {args.taper:g}")
    if args.twist is not None:
        P = edits.twist(P, args.twist, axis=args.axis)
        done.append(f"twist {args.twist:g} deg about {args.axis}")
    if args.bend is not None:
        P = edits.bend(P, args.bend, axis=args.axis, toward=args.toward)
        done.append(f"bend {args.bend:g} deg towards {args.toward}")
    cons = [(np.array(a), np.array(b)) for a, b in (args.drag or [])]
    if cons:
        done.append(f"{len(cons)} dragged point{'s' * (len(cons) > 1)}")
    preserve = args.preserve != "none"
    if preserve and not mesh.is_closed:
        e = mesh.edge_report()
        raise ValueError(f"{args.input} is not a closed mesh ({e['boundary_edges']} boundary, "
                         f"{e['nonmanifold_edges']} non-manifold, {e['misoriented_edges']} misoriented edges), "
                         f"so it has no volume to keep; use --preserve none for a plain FFD")
    if args.multires is not None:
        return _deform_multires(args, mesh, lat, P, preserve, done, cons, bar)
    d = Deformer(mesh, lat, backend=args.backend, outside=args.outside)
    bar(2, 4, "deforming")
    t0 = time.perf_counter()
    weights = "auto" if args.weights == "auto" and preserve else None
    r = d.deform(P, preserve_volume=preserve, axes=args.preserve if preserve else "xyz", constraints=cons or None,
                 weights=weights)
    ms = 1e3 * (time.perf_counter() - t0)
    out = Mesh(r.vertices, mesh.faces)
    bar(3, 4, "writing")
    from ..io import save_mesh
    save_mesh(args.output, out)
    bar(4, 4)
    bar.close()
    print(f"{args.input}: {mesh.n_vertices:,} vertices, {mesh.n_faces:,} faces; lattice "
          f"{'x'.join(map(str, lat.shape))} degree {args.degree}; {', '.join(done) or 'no edit (identity)'}")
    if up_note:
        print(f"  {up_note}")
    if mesh.is_closed:
        rest = r.rest_volume
        plain = f"plain FFD {r.volume_before:.6g} ({100 * (r.volume_before - rest) / rest:+.2f} %)"
        if preserve:
            kept = f"preserved along {args.preserve} {r.volume:.6g} (relative error {(r.volume - rest) / rest:+.1e})"
        elif cons:
            kept = f"with the dragged points {r.volume:.6g} ({100 * (r.volume - rest) / rest:+.2f} %, not preserved)"
        else:
            kept = "not preserved (--preserve none)"
        print(f"  volume: rest {rest:.6g}, {plain}, {kept}")
    else:
        print("  the mesh is not closed: no volume (and no volume correction)")
    if cons:
        print(f"  dragged points reached their targets to {r.constraint_error:.1e}")
    rep = d.check_folds(r.control_points)
    print(f"  folds: {rep.verdict()}")
    if preserve and rep.mesh_folded:
        _suggest_unfolded(args, d, P, cons)
    print(f"  {r.backend} backend, {ms:.1f} ms; wrote {args.output}")
    if args.render:
        _render_png(args.render, d, r, args.size, args.up, args.lattice_style, args.view)
        print(f"  picture: {args.render}")
    return 0


def _suggest_unfolded(args, d, P, cons) -> None:
    """The correction folds the mesh: tries the other ways of correcting it (local
    weights, other axes) and prints which keep the mesh fold-free."""
    from .. import SolverError
    tries = []
    if args.weights != "auto":
        tries.append(("--weights auto", dict(axes=args.preserve, weights="auto")))
    others = "".join(a for a in "xyz" if a != args.axis)
    for axes in (others, args.axis, "xyz"):
        if axes != args.preserve:
            tries.append((f"--preserve {axes}", dict(axes=axes, weights=None)))
            if args.weights != "auto":
                tries.append((f"--preserve {axes} --weights auto", dict(axes=axes, weights="auto")))
    good, bad = [], []
    for flags, kw in tries:
        try:
            t = d.deform(P, preserve_volume=True, constraints=cons or None, **kw)
        except (SolverError, ValueError):
            continue
        (bad if d.check_folds(t.control_points).mesh_folded else good).append(flags)
    finer = "x".join(str(n + max(2, n // 2)) for n in args.lattice)
    if good:
        print(f"  the volume correction folds cells the mesh occupies; without such folds: {', '.join(good)} "
              f"(or more control points, e.g. --lattice {finer})")
    else:
        print(f"  the volume correction folds cells the mesh occupies, and so do {', '.join(bad) or 'the other axes'}; try a "
              f"milder edit or more control points (e.g. --lattice {finer})")


def _deform_multires(args, mesh, lat, P, preserve, done, cons, bar) -> int:
    """``deform --multires SMOOTHING``: the edit applied to the mesh's smooth base,
    details rebuilt along the deformed base normals (Marinov et al.); with --preserve the
    base mesh's volume is kept exactly, with --drag the lattice map takes the dragged
    points to their targets. --render draws rest | FFD of the fine mesh | multiresolution
    with what each did to the details."""
    from ..io import save_mesh
    from ..mesh import Mesh
    from ..multires import Multires, MultiresDeformer

    mr = Multires(mesh, smoothing=args.multires, progress=lambda k, n: bar(k, n, "decomposing"))
    md = MultiresDeformer(mr, lat, backend=args.backend, outside=args.outside)
    bar(2, 4, "deforming")
    t0 = time.perf_counter()
    axes = args.preserve if preserve else "xyz"
    weights = "auto" if args.weights == "auto" and preserve else None
    r = md.deform(P, preserve_volume=preserve, axes=axes, volume="base", constraints=cons or None, weights=weights)
    ms = 1e3 * (time.perf_counter() - t0)
    bar(3, 4, "writing")
    save_mesh(args.output, Mesh(r.vertices, mesh.faces))
    bar(4, 4)
    bar.close()
    print(f"{args.input}: {mesh.n_vertices:,} vertices, {mesh.n_faces:,} faces; lattice "
          f"{'x'.join(map(str, lat.shape))} degree {args.degree}; {', '.join(done) or 'no edit (identity)'}")
    print(f"  {mr}")
    if mesh.is_closed:
        kept = f"base volume kept along {args.preserve} (relative error {r.base_volume_error:.1e})" if preserve \
            else "not preserved (--preserve none)"
        print(f"  volume: rest {r.rest_volume:.6g}, multiresolution result {r.volume:.6g} "
              f"(relative error {r.volume_error:.1e}); {kept}")
    if cons:
        print(f"  the lattice map takes the dragged points to their targets to {r.constraint_error:.1e} (the "
              "rebuilt surface follows its base there)")
    print(f"  {r.backend} backend, {ms:.1f} ms; wrote {args.output}")
    if args.render:
        from .._png import save_png
        from ..deformer import Deformer
        from ..multires_picture import render_multires_comparison
        plain = Deformer(mesh, lat, backend=md.backend, outside=args.outside).deform(
            P, preserve_volume=preserve, axes=axes, constraints=cons or None, weights=weights)
        save_png(args.render, render_multires_comparison(md, plain, r, size=args.size, up=args.up, view=args.view))
        print(f"  picture: {args.render} (rest | FFD of the fine mesh | multiresolution, with the detail changes)")
    return 0


def _nonnegative_int(text: str):
    try:
        n = int(text)
    except ValueError:
        n = -1
    if n < 0:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0, got {text!r}")
    return n


def _check_outputs(args, default_size) -> None:
    """The checks of OUT, --render and --size that ``deform`` and ``subdiv`` share,
    all before any work (a bad value leaves OUT untouched)."""
    ext = _extension(args.output)
    from ..io import FORMATS as formats, _require_writer  # FORMATS is empty without mesh file I/O
    _require_writer(args.output, f"OUT {args.output!r}")  # before reading and deforming, not after
    if formats and ext not in formats:
        raise _UsageError(f"OUT: unknown mesh format {ext or '(none)'!r} of {args.output!r}; "
                          f"expected one of {', '.join('.' + f for f in formats)}")
    if args.render and not args.render.lower().endswith(".png"):
        raise _UsageError(f"--render: expected a .png file name, got {args.render!r}")
    if args.size is not None and not args.render:
        raise _UsageError("--size: only applies to the --render picture; add --render PNG or drop --size")
    if args.size is None:
        args.size = default_size
    for path in (args.output, args.render):
        out_dir = os.path.dirname(os.path.abspath(path)) if path else None
        if out_dir and not os.path.isdir(out_dir):
            raise FileNotFoundError(2, "output folder does not exist", out_dir)
    if not args.in_place and _same_file(args.input, args.output):
        raise _UsageError(f"OUT is IN ({args.output!r}): that would replace the input mesh; give another "
                          "OUT, or --in-place to replace IN on purpose (it is replaced only once the new file "
                          "is complete)")
    if args.render and _same_file(args.input, args.render):
        raise _UsageError(f"--render: {args.render!r} is the input mesh file")


def _cmd_subdiv(args) -> int:
    if args.control_vertices is not None and args.control_vertices < 4:
        raise _UsageError(f"--control-vertices: expected at least 4 (a tetrahedron), got {args.control_vertices}")
    if args.fairness < 0:
        raise _UsageError(f"--fairness: expected a weight >= 0, got {args.fairness}")
    _check_outputs(args, (1600, 480))
    from ..subdivision import _require
    _require("vpffd subdiv")  # before reading a large file
    # stages: read, decompose, deform, write
    bar = Progress("subdiv", 4)
    try:
        return _subdiv(args, bar)
    finally:
        bar.close()


def _subdiv(args, bar) -> int:
    """``vpffd subdiv``: the mesh as a displaced subdivision surface (Marinov et al., §5),
    control points moved by the drags, the detailed mesh rebuilt and written."""
    import numpy as np

    from ..io import save_mesh
    from ..mesh import Mesh
    from ..subdivision import SubdivisionMultires
    from ..subdivision_edits import drag
    from ..subdivision_picture import normal_error_deg

    mesh = _load(args.input)
    if args.preserve_volume and not mesh.is_closed:
        e = mesh.edge_report()
        raise ValueError(f"{args.input} is not a closed mesh ({e['boundary_edges']} boundary, "
                         f"{e['nonmanifold_edges']} non-manifold, {e['misoriented_edges']} misoriented edges), "
                         f"so it has no volume to keep; drop --preserve-volume")
    bar(1, 4, "decomposing")
    try:
        sm = SubdivisionMultires(mesh, scheme=args.scheme, control_vertices=args.control_vertices,
                                 fairness=args.fairness, iterations=args.iterations,
                                 max_unresolved=args.max_unresolved,
                                 progress=lambda k, n: bar(k, n, "decomposing"))
    except ValueError as e:
        if "max_unresolved" not in str(e):
            raise
        raise ValueError(f"{e} (on the command line: --max-unresolved N)") from None
    C, edit = sm.control_points, None
    if args.drag:
        edit = drag(sm, [a for a, _ in args.drag], [b for _, b in args.drag])
        C = edit.control_points
    bar(2, 4, "deforming")
    t0 = time.perf_counter()
    r = sm.deform(C, preserve_volume=args.preserve_volume)
    ms = 1e3 * (time.perf_counter() - t0)
    bar(3, 4, "writing")
    save_mesh(args.output, Mesh(r.vertices, mesh.faces))
    bar(4, 4)
    bar.close()
    diag = float(np.linalg.norm(np.ptp(mesh.vertices, axis=0)))
    scheme = {"loop": "Loop", "catmark": "Catmull-Clark"}[args.scheme]
    print(f"{args.input}: {mesh.n_vertices:,} vertices, {mesh.n_faces:,} faces; {scheme} control mesh of "
          f"{sm.n_control:,} points (decimated), {args.iterations} fit round{'s' * (args.iterations != 1)}")
    print(f"  fit RMS |p - S|: {sm.rms_initial:.4g} before, {sm.rms_final:.4g} after (bounding-box diagonal "
          f"{diag:.4g}); decomposed in {sm.seconds:.2f} s")
    n_bad = len(sm.unresolved)
    first = ", ".join(str(int(i)) for i in sm.unresolved[:5])
    print(f"  unresolved foot points: {n_bad}" + (f" (first: {first}; they keep their nearest point)" if n_bad
                                                   else " (every foot point exact)"))
    if edit is not None:
        reach = np.linalg.norm(r.vertices[edit.vertices] - np.array([b for _, b in args.drag]), axis=1)
        print(f"  {len(args.drag)} dragged point{'s' * (len(args.drag) > 1)} (snapped to vertices up to "
              f"{edit.snap_distances.max():.3g} away) moved {len(edit.moved)} control points; the dragged "
              f"vertices are within {reach.max():.3g} of their targets")
    else:
        print("  no edit (--drag none): the identity frame")
    if mesh.is_closed:
        kept = (f"; base volume kept (relative error {r.base_volume_error:+.1e})" if args.preserve_volume
                else " (not preserved: --preserve-volume keeps the base's volume)")
        print(f"  volume: rest {r.rest_volume:.6g}, result {r.volume:.6g} ({100 * r.volume_error:+.3f} %){kept}")
    else:
        print("  the mesh is not closed: no volume")
    a = normal_error_deg(r, mesh.faces)
    print(f"  approximate normals against the deformed mesh's: mean {np.nanmean(a):.3f} deg, max "
          f"{np.nanmax(a):.2f} deg")
    print(f"  frame {ms:.1f} ms ({sm.bytes_per_vertex:.0f} bytes per vertex); wrote {args.output}")
    if args.render:
        from .. import save_png
        from ..subdivision_picture import render_subdivision_edit
        up = args.up
        if up is None:
            from ..views import guess_up_axis
            up, why = guess_up_axis(mesh)
            print(f"  up axis {up} (guessed: {why}; --up to change)")
        save_png(args.render, render_subdivision_edit(sm, r, size=args.size, up=up, angles=a, view=args.view))
        print(f"  picture: {args.render}")
    return 0


def _cmd_info(args) -> int:
    mesh = _load(args.mesh)
    report = mesh.check()
    print(f"{args.mesh}: {report}")
    return 0 if report.is_volume else EXIT_ERROR


def _cmd_bench(args) -> int:
    from .benchmark import run_benchmark
    _check_lattice(args)
    bar = Progress("bench", 1)
    try:
        run_benchmark(include_shared=not args.no_shared, repeats=args.repeats, with_csr=not args.no_csr,
                      out=args.json, shape=args.lattice, degree=args.degree, progress=bar)
    finally:
        bar.close()
    return 0


def _cmd_devices(args) -> int:
    from .. import _core, available_backends
    from ..deformer import _requested_precision
    wanted = _requested_precision()
    devices, why = _core.vulkan_devices() if _core.has_vulkan else ([], "")
    threads = f" ({_core.max_threads()} threads)" if _core.has_openmp() else ""
    print("backends, best first: " + ", ".join(b + (threads if b == "openmp" else "")
                                               for b in available_backends(devices)))
    if not _core.has_vulkan:
        print("Vulkan: not in this build (it needs libvulkan-dev, glslc and libvulkan-volk-dev at build time)")
        return 0
    if not devices:
        print(f"Vulkan: no device ({why})")
        return 0
    print("Vulkan devices (backend='vulkan', device=INDEX or part of the name):")
    for d in devices:
        if not d["suitable"]:
            use = f"unsuitable: {d['reason']}"
        else:
            sums = "float-float" if wanted == "float-float" or not d["float64"] else "float64"
            use = f"sums in {sums}" + (" (VPFFD_VULKAN_PRECISION)" if wanted != "auto" else "")
            if wanted == "float64" and not d["float64"]:
                use = "VPFFD_VULKAN_PRECISION=float64, but it has no shaderFloat64"
            if d["type"] == "cpu":
                use += "; a software device: backend='auto' takes it only when named"
        print(f"  {d['index']}  {d['name']}  [{d['type']}, {d['memory_bytes'] / 2 ** 30:.1f} GiB, "
              f"Vulkan {d['api_version']}]  {use}")
    return 0


# --- parser -----------------------------------------------------------------------
def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="vpffd", description="Exact volume-preserving B-spline free-form deformation "
                     "(Hahmann et al. 2012) of triangle meshes.",
                     epilog="Run 'vpffd COMMAND --help' for the options of each command.")
    parser.add_argument("--version", action="version", version=f"vpffd {_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    fmt = _Formatter
    # Every command takes -v (after its name: "vpffd deform -v IN OUT").
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("-v", "--verbose", action="count", default=0,
                        help="log what runs to stderr: stages, file reads and writes with sizes and times "
                             "(-vv: more detail)")
    view_help = ("camera of the --render picture: front, back, left, right, top, bottom (sides of the model, "
                 "its up axis upwards) or AZIMUTH,ELEVATION in degrees (azimuth from the front towards the "
                 "model's right; default: a three-quarter view from the front, right and above)")

    def add_parser(name, **kw):
        return sub.add_parser(name, parents=[common], **kw)

    p = add_parser("demo", formatter_class=fmt,
                       help="the paper's twisting cube and bouncing ball, with and without volume preservation",
                       description="Animates the paper's twisting cube (Figure 6) and bouncing ball (Figure 1) on "
                       "built-in meshes, plain FFD against the volume-preserving FFD restricted to xy, z and xyz; "
                       "prints the volume change of every frame and writes PNG frames, animated GIFs, key-frame "
                       "sheets, volume.png and volume.csv. Then objects moving through a fixed deformation (a shoal "
                       "round a ring, walkers on a Moebius band), multiresolution edits (a bumpy body bent: "
                       "FFD of the fine mesh against base + details, with the normal error; a bumpy ball squashed, "
                       "with how much each changed the details) and a displaced subdivision surface edit (control "
                       "points of a detailed body pulled, with the control mesh, the limit surface and the normal "
                       "error).")
    p.add_argument("--out", default="demo_out", metavar="DIR", help="output folder (created)")
    p.add_argument("--size", type=_size, default=(320, 240), metavar="WxH",
                   help="pixels of one panel (default: 320x240)")
    p.add_argument("--quick", action="store_true", help="smaller meshes and fewer frames")
    p.add_argument("--no-render", action="store_true", help="numbers and the volume plot only, no frames")
    p.set_defaults(func=_cmd_demo)

    p = add_parser("deform", formatter_class=fmt, help="deform a mesh file with lattice edits",
                       description="Deforms a mesh file with a lattice around it (edits applied in the order "
                       "squash, taper, twist, bend, then dragged points) and keeps its volume exactly.")
    p.add_argument("input", metavar="IN", help="mesh file to read (the formats of vpffd.load_mesh)")
    p.add_argument("output", metavar="OUT", help="mesh file to write; the extension picks the format "
                   "(written to a temporary file first: a failed write leaves an existing OUT as it was)")
    p.add_argument("--in-place", action="store_true", help="allow OUT to be IN (the input file is replaced)")
    p.add_argument("--lattice", type=_lattice_shape, default=(8, 8, 8), metavar="NxNxN",
                   help="control points per axis (default: 8x8x8)")
    p.add_argument("--degree", type=int, default=3, help="B-spline degree, 1..5")
    p.add_argument("--padding", type=_finite, default=0.05, help="lattice margin, in box extents")
    p.add_argument("--outside", choices=["error", "extrapolate"], default="error",
                   help="points outside the lattice (--drag sources): refuse, or continue the boundary "
                        "polynomials")
    p.add_argument("--twist", type=_finite, metavar="DEG", help="twist the top by DEG degrees about --axis")
    p.add_argument("--bend", type=_finite, metavar="DEG", help="bend the --axis extent into an arc of DEG degrees")
    p.add_argument("--taper", type=_finite, metavar="FACTOR", help="scale the top's cross-section by FACTOR")
    p.add_argument("--squash", type=_finite, metavar="FACTOR", help="scale along --axis by FACTOR")
    p.add_argument("--axis", choices=["x", "y", "z"], default=None,
                   help="axis of the edits (default: the up axis, so --squash squashes downwards)")
    p.add_argument("--up", choices=["x", "y", "z"], default=None,
                   help="the model's up axis: upwards in the picture and the default --axis (default: guessed "
                        "from a flat base or the file's convention, and printed)")
    p.add_argument("--toward", choices=["x", "y", "z"],
                   help="direction --bend curves towards (default: x, or y when --axis is x)")
    p.add_argument("--drag", type=_drag, action="append", metavar="X,Y,Z:TX,TY,TZ",
                   help="move the rest-space point X,Y,Z to TX,TY,TZ exactly (repeatable)")
    p.add_argument("--preserve", choices=["xyz", "xy", "xz", "yz", "x", "y", "z", "none"], default="xyz",
                   help="axes the volume correction may move control points along, or none")
    p.add_argument("--weights", choices=["uniform", "auto"], default="uniform",
                   help="how the volume correction spreads: the least change of all control points alike, or "
                        "'auto': weighted by where the edit changed the volume, so the correction stays near the "
                        "edit (Python: deform(weights='auto'))")
    p.add_argument("--backend", choices=["auto", "openmp", "serial", "vulkan"], default="auto",
                   help="where frames run (default auto: a GPU for large meshes when there is one; the Vulkan "
                        "device and precision follow VPFFD_VULKAN_DEVICE and VPFFD_VULKAN_PRECISION)")
    p.add_argument("--multires", type=_finite, metavar="SMOOTHING",
                   help="multiresolution edit: deform the mesh's base faired by SMOOTHING implicit steps and "
                        "rebuild the details along its normals (keeps the base volume); with --render the picture "
                        "is rest | FFD of the fine mesh | multiresolution, with the detail changes measured")
    p.add_argument("--render", metavar="PNG",
                   help="also write a picture: rest | plain FFD | volume-preserved, captioned with the volumes, "
                        "coloured by the local volume change det J")
    p.add_argument("--size", type=_size, default=None, metavar="WxH",
                   help="--render picture size (default: 1600x600; only with --render)")
    p.add_argument("--view", type=_view, default=None, metavar="VIEW", help=view_help)
    p.add_argument("--lattice-style", choices=["none", "faint", "full"], default="faint",
                   help="the lattice in the --render picture: hidden, thin translucent lines, or lines and "
                        "control points")
    p.set_defaults(func=_cmd_deform)

    p = add_parser("subdiv", formatter_class=fmt, help="edit a mesh as a displaced subdivision surface",
                       description="Represents a detailed mesh as the limit surface of a coarse control mesh "
                       "(Loop or Catmull-Clark, decimated from the mesh and fitted) plus a normal displacement "
                       "per vertex (Marinov et al., section 5), moves control points so that the dragged points "
                       "follow, rebuilds the details on the deformed surface and writes the result.")
    p.add_argument("input", metavar="IN", help="mesh file to read (the formats of vpffd.load_mesh)")
    p.add_argument("output", metavar="OUT", help="mesh file to write; the extension picks the format "
                   "(written to a temporary file first: a failed write leaves an existing OUT as it was)")
    p.add_argument("--in-place", action="store_true", help="allow OUT to be IN (the input file is replaced)")
    p.add_argument("--control-vertices", type=_positive_int, metavar="N",
                   help="points of the control mesh (default: 1 %% of the vertices, at least 64)")
    p.add_argument("--scheme", choices=["loop", "catmark"], default="loop",
                   help="subdivision scheme of the limit surface: Loop or Catmull-Clark")
    p.add_argument("--iterations", type=_nonnegative_int, default=2,
                   help="fit rounds (least squares and foot-point updates)")
    p.add_argument("--fairness", type=_finite, default=1e-3, help="weight of the fit's fairness term")
    p.add_argument("--max-unresolved", type=_nonnegative_int, default=0,
                   help="vertices allowed without an exact foot point (open meshes need some near the rim)")
    p.add_argument("--drag", type=_drag, action="append", metavar="X,Y,Z:TX,TY,TZ",
                   help="move the surface at the vertex nearest X,Y,Z to TX,TY,TZ: the least change of the "
                        "control points that moves that vertex's limit point by the offset (repeatable)")
    p.add_argument("--preserve-volume", action="store_true",
                   help="correct the control points so that the base surface keeps its volume exactly "
                        "(closed meshes)")
    p.add_argument("--render", metavar="PNG",
                   help="also write a picture: control mesh over the limit surface, before and after, the "
                        "detailed result and its approximate-normal error as colour")
    p.add_argument("--size", type=_size, default=None, metavar="WxH",
                   help="--render picture size (default: 1600x480; only with --render)")
    p.add_argument("--up", choices=["x", "y", "z"], default=None,
                   help="the model's up axis in the picture (default: guessed and printed)")
    p.add_argument("--view", type=_view, default=None, metavar="VIEW", help=view_help)
    p.set_defaults(func=_cmd_subdiv)

    p = add_parser("info", formatter_class=fmt, help="check a mesh file (closed, oriented, volume, ...)",
                       description="Reads a mesh file and reports what vpffd needs of it: closed, consistently "
                       "oriented and outward, its volume. Exit status 1 when it cannot be volume-preserved.")
    p.add_argument("mesh", metavar="MESH", help="mesh file")
    p.set_defaults(func=_cmd_info)

    p = add_parser("bench", formatter_class=fmt, help="CPU benchmark table",
                       description="Times FFD, the volume coefficients and whole frames on built-in meshes "
                       "(and the shared test meshes when present); prints a markdown table.")
    p.add_argument("--repeats", type=_positive_int, default=7, help="timed runs per case (median)")
    p.add_argument("--lattice", type=_lattice_shape, default=(10, 10, 10), metavar="NxNxN",
                   help="control points per axis (default: 10x10x10)")
    p.add_argument("--degree", type=int, default=3, help="B-spline degree")
    p.add_argument("--no-shared", action="store_true", help="built-in meshes only")
    p.add_argument("--no-csr", action="store_true", help="skip the CSR coefficient method")
    p.add_argument("--json", metavar="FILE", help="also write the rows as JSON")
    p.set_defaults(func=_cmd_bench)

    p = add_parser("devices", formatter_class=fmt, help="list the backends and Vulkan devices",
                       description="Lists the backends this build can run here and the Vulkan devices with "
                       "what vpffd would do with each.")
    p.set_defaults(func=_cmd_devices)
    return parser


def _version() -> str:
    try:
        from .. import __version__
        return __version__
    except ImportError:  # pragma: no cover - the compiled core is missing
        return "(not built)"


def _one_line(e: BaseException) -> str:
    if isinstance(e, OSError) and e.filename is not None and e.strerror:
        msg = f"{e.filename}: {e.strerror}"
    else:
        msg = str(e) or type(e).__name__
    return " ".join(msg.split())


class _Elapsed(logging.Formatter):
    """``vpffd CMD: [  1.2 s] message``: seconds since the command started."""

    def __init__(self, prog):
        super().__init__()
        self.prog, self.start = prog, time.perf_counter()

    def format(self, record):
        return f"{self.prog}: [{time.perf_counter() - self.start:6.1f} s] {record.getMessage()}"


def _verbose_logging(prog, verbose: int):
    """A stderr handler on the "vpffd" logger for -v (INFO) and -vv (DEBUG), or None;
    ``main`` takes it off again when the command ends."""
    if not verbose:
        return None
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(_Elapsed(prog))
    logger = logging.getLogger("vpffd")
    handler.previous_level = logger.level
    logger.setLevel(logging.DEBUG if verbose > 1 else logging.INFO)
    logger.addHandler(handler)
    return handler


def main(argv=None) -> int:
    """Runs the command line ``argv`` (default ``sys.argv[1:]``); returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    prog = f"vpffd {args.command}"

    def one_line_warning(message, category, filename, lineno, file=None, line=None):
        print(f"{prog}: warning: {' '.join(str(message).split())}", file=sys.stderr)

    handler = _verbose_logging(prog, getattr(args, "verbose", 0))
    try:
        with warnings.catch_warnings():
            warnings.showwarning = one_line_warning
            return args.func(args)
    except _UsageError as e:
        print(f"{prog}: error: {e} (see '{prog} --help')", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print(f"{prog}: interrupted", file=sys.stderr)
        return 130
    except Exception as e:  # one line, not a traceback, for whatever went wrong
        if os.environ.get("VPFFD_TRACEBACK"):
            raise
        known = isinstance(e, (ValueError, TypeError, RuntimeError, OSError))
        kind = "error" if known else f"internal error ({type(e).__name__})"
        print(f"{prog}: {kind}: {_one_line(e)}", file=sys.stderr)
        return EXIT_ERROR
    finally:
        if handler is not None:
            logger = logging.getLogger("vpffd")
            logger.removeHandler(handler)
            logger.setLevel(handler.previous_level)


if __name__ == "__main__":
    sys.exit(main())
