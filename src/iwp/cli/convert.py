"""``iwp convert``: convert a log (CSV, MAT, Parquet, angle log) to the iwp format."""

from __future__ import annotations

import sys
import warnings

from ..errors import InputError

_DESCRIPTION = """\
Read an experiment log and write it in the iwp format (CSV, or Parquet/MAT by
the extension of OUT or --to), after checking it: required columns t, q1, q2,
numbers only, no NaN/inf, strictly increasing and regular time.
Examples:
  iwp convert swing.txt --from angle-log --out swing.csv
  iwp convert run.mat --map t=time,q1=theta,q2=phi,u=u --out run.csv
  iwp convert run.csv --resample --t-start 1 --t-end 20 --out run.parquet
"""


def _parse_map(text: str | None) -> dict[str, str] | None:
    if text is None:
        return None
    mapping: dict[str, str] = {}
    for item in text.split(","):
        item = item.strip()
        if not item:
            continue
        key, sep, value = item.partition("=")
        key, value = key.strip(), value.strip()
        if not sep or not key or not value:
            raise InputError(f"--map: expected NAME=COLUMN items separated by commas, got {item!r}")
        if key in mapping:
            raise InputError(f"--map: {key} given twice")
        mapping[key] = value
    if not mapping:
        raise InputError("--map: empty mapping")
    return mapping


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "convert",
        help="check a log and convert it to the iwp CSV/Parquet/MAT format",
        description=_DESCRIPTION,
        formatter_class=__import__("argparse").RawDescriptionHelpFormatter,
    )
    p.add_argument("input", metavar="IN", help="input file")
    p.add_argument(
        "--from", dest="from_format", choices=["csv", "mat", "parquet", "angle-log"],
        help="input format (default: from the extension: .csv/.txt csv, .mat mat, "
        ".parquet/.pq parquet)",
    )
    p.add_argument("--out", "-o", required=True, metavar="OUT", help="output file")
    p.add_argument(
        "--to", dest="to_format", choices=["csv", "parquet", "mat"],
        help="output format (default: from the extension of OUT)",
    )
    p.add_argument("--force", action="store_true", help="overwrite OUT if it exists")
    p.add_argument(
        "--map", dest="mapping", metavar="NAME=COL[,...]",
        help="iwp column = column/variable in the file, e.g. t=time,q1=theta,q2=phi,u=u "
        "(csv, mat, parquet)",
    )
    p.add_argument("--struct", metavar="NAME", help="MAT struct holding the signals (mat)")
    p.add_argument("--rig", metavar="RIG.json",
                   help="rig description: the log's columns, units, zero, input and drive (csv, mat; "
                   "see docs/rig-description.md)")
    p.add_argument(
        "--degrees", action="store_true",
        help="angles are in degrees and velocities in deg/s: convert to rad, rad/s",
    )
    p.add_argument(
        "--resample", action="store_true",
        help="accept irregular sampling: interpolate linearly onto a uniform grid (median step)",
    )
    p.add_argument(
        "--sampling-tol", type=float, default=0.01, metavar="REL",
        help="largest relative deviation of a time step from the median step (default 0.01)",
    )
    p.add_argument(
        "--min-samples", type=int, default=10, metavar="N",
        help="fewest samples accepted (default 10)",
    )
    p.add_argument("--sample-rate", type=float, metavar="HZ", help="sampling rate (angle-log)")
    p.add_argument(
        "--angle-unit", choices=["deg", "rad"], default=None,
        help="unit of the angles in the file (angle-log; default deg)",
    )
    p.add_argument(
        "--zero", choices=["down", "up"], default=None,
        help="the file's zero angle: pendulum down (default) or up (angle-log)",
    )
    p.add_argument("--t-start", type=float, metavar="S", help="keep samples from this time [s]")
    p.add_argument("--t-end", type=float, metavar="S", help="keep samples up to this time [s]")
    p.set_defaults(func=run)


def _reader_options(args, fmt: str) -> dict:
    """Build the reader options, refusing flags that do not apply to ``fmt``."""
    opts: dict = {}

    def refuse(flag: str, given: bool) -> None:
        if given:
            raise InputError(f"{flag} does not apply to --from {fmt}")

    if fmt == "angle-log":
        refuse("--map", args.mapping is not None)
        refuse("--struct", args.struct is not None)
        refuse("--resample", args.resample)
        if args.degrees and args.angle_unit == "rad":
            raise InputError("--degrees contradicts --angle-unit rad")
        opts["angle_unit"] = args.angle_unit or "deg"
        opts["zero"] = args.zero or "down"
        if args.sample_rate is not None:
            opts["sample_rate"] = args.sample_rate
        opts["min_samples"] = args.min_samples
        return opts
    refuse("--sample-rate", args.sample_rate is not None)
    refuse("--angle-unit", args.angle_unit is not None)
    refuse("--zero", args.zero is not None)
    if getattr(args, "rig", None) is not None:
        if fmt == "parquet":
            raise InputError("--rig reads CSV and .mat logs, not --from parquet")
        for flag, given in (("--map", args.mapping is not None), ("--degrees", args.degrees)):
            if given:
                raise InputError(f"{flag} does not apply with --rig (the rig description gives columns and units)")
        opts["rig"] = args.rig
        if args.struct is not None:
            opts["struct"] = args.struct
        opts.update(resample=args.resample, min_samples=args.min_samples, sampling_tol=args.sampling_tol)
        return opts
    if fmt != "mat":
        refuse("--struct", args.struct is not None)
    elif args.struct is not None:
        opts["struct"] = args.struct
    mapping = _parse_map(args.mapping)
    if mapping is not None:
        opts["mapping"] = mapping
    opts.update(
        degrees=args.degrees,
        resample=args.resample,
        min_samples=args.min_samples,
        sampling_tol=args.sampling_tol,
    )
    return opts


def run(args) -> int:
    from .. import data as io

    fmt = args.from_format or io.format_of(args.input)
    opts = _reader_options(args, fmt)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        data = io.convert(
            args.input,
            args.out,
            from_format=fmt,
            to_format=args.to_format,
            force=args.force,
            t_start=args.t_start,
            t_end=args.t_end,
            **opts,
        )
    for w in caught:
        print(f"iwp: warning: {w.message}", file=sys.stderr)
    inp = data.input_name or "none (zero input)"
    print(
        f"{args.out}: {data.n_samples} samples, Ts = {data.Ts:.6g} s, duration "
        f"{data.duration:.6g} s, input {inp} (from {args.input}, {fmt})"
    )
    return 0
