"""``biped model``: W's 13-body biped for your own subject (de Leva 1996, both sexes).

Writes an MJCF file with the shipped biped's bodies, joint names, axes and motors, segment
parameters scaled from de Leva's Table 4 to the subject's stature and mass, and W's initial
posture (feet flat, soles 5 mm above the floor) as its keyframe. Use it with ``--model`` on
``biped push``, ``biped sweep`` and ``biped walk``. Thin: the work is
:mod:`biped.models.anthropometry`; see docs/model.md.
"""

from __future__ import annotations

from pathlib import Path

from biped.cli._common import check_file_writable
from biped.errors import ModelError


def register(subparsers) -> None:
    from biped.models.anthropometry import MASS_RANGE_KG, STATURE_RANGE_M

    p = subparsers.add_parser(
        "model",
        help="write W's biped for a subject of given stature, mass and sex (de Leva 1996)",
        description="Write W's 13-body, 18-DOF biped as an MJCF file with de Leva's (1996) segment "
        "parameters for a subject; run it with --model FILE on push, sweep and walk. "
        "See docs/model.md.",
    )
    p.add_argument(
        "--stature",
        type=float,
        required=True,
        metavar="M",
        help=f"standing height [m], {STATURE_RANGE_M[0]:g} to {STATURE_RANGE_M[1]:g}",
    )
    p.add_argument(
        "--mass",
        type=float,
        required=True,
        metavar="KG",
        help=f"body mass [kg], {MASS_RANGE_KG[0]:g} to {MASS_RANGE_KG[1]:g} (the model's total mass)",
    )
    p.add_argument(
        "--sex",
        choices=("male", "female"),
        required=True,
        help="which of de Leva's tables (Table 4, males or females)",
    )
    p.add_argument("--out", required=True, metavar="FILE.xml", help="MJCF file to write")
    p.add_argument("--overwrite", action="store_true", help="replace an existing FILE.xml")
    p.set_defaults(func=run)


def _check_out(out: str, overwrite: bool) -> Path:
    path = Path(out)
    if path.suffix.lower() != ".xml":
        raise ModelError(f"--out must name an .xml file (the MJCF model); got {out!r}")
    if path.is_dir():
        raise ModelError(f"--out {out!r} is a folder; give a file name ending in .xml")
    if path.exists() and not overwrite:
        raise ModelError(f"--out {out!r} already exists; choose another name or pass --overwrite")
    if path.exists():
        head = path.read_bytes()[:4096].lstrip()
        if not head.startswith(b"<"):
            raise ModelError(f"--out {out!r} exists and is not an XML file; refusing to replace it")
    check_file_writable(path)  # before any work: a file in the way, an unwritable folder
    return path


def run(args) -> int:
    from biped.models import anthropometry as a
    from biped.models.subject import check_biped

    subject = a.Subject(args.stature, args.mass, args.sex)  # validated: ranges in the message
    out = _check_out(args.out, args.overwrite)
    out.parent.mkdir(parents=True, exist_ok=True)
    a.write(out, subject)
    check_biped(out)
    import mujoco

    m = mujoco.MjModel.from_xml_path(str(out))
    z0 = a.initial_com_height(subject)
    rows = [
        (
            "subject",
            (
                f"{args.sex}, {args.stature:g} m, {args.mass:g} kg "
                f"(de Leva 1996 Table 4, {args.sex}s, scale {subject.scale:.4f})"
            ),
        ),
        ("total mass (MuJoCo)", f"{float(m.body_mass.sum()):.4f} kg"),
        ("initial central-body COM", f"{z0:.4f} m (W's posture, soles 5 mm up; W's biped: 1.035 m)"),
        ("written", str(out)),
        ("use it", f"biped push --model {out}"),
    ]
    w = max(len(k) for k, _ in rows)
    print("\n".join(f"  {k:<{w}}  {v}" for k, v in rows))
    return 0
