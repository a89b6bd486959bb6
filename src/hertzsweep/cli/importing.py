"""``hertzsweep import FILE -o OUT.nc``: measurements into a ``measured`` dataset, and
``hertzsweep export IN.nc -o OUT``: a dataset in the formats rigs read.

(The command is ``import``; a Python module cannot be named so.)
"""

from __future__ import annotations

import click

from ..api.choices import IMPORT_PRESETS
from . import options
from .group import cli

COLUMNS_HELP = (
    "A lock-in table's columns: QUANTITY=COLUMN,... with quantities frequency, x, y (or r, "
    "phase), harmonic, direction, sigma, e.g. frequency=freq,x=X,y=Y."
)
MAP_HELP = "The same column map as a TOML file: a [columns] table (and any option below)."
PRESET_HELP = "An instrument's own file: labone-sweeper (LabOne sweeper CSV) or sr8xx."
PHASE_HELP = (
    "The phase column is the instrument's lead theta (lock-in: phi_k = -theta) or the "
    "SPEC's lag phi_k (spec)."
)
LEVEL_HELP = "The level F/F_s of a file that holds none."
FORCE_HELP = "The level as a force amplitude [N] (with --static-load or --rig)."
MASS_HELP = "The moving mass m [kg], to convert a UFF accelerance, mobility or receptance."
RIG_HELP = "A rig or scene file: its moving mass (UFF accelerance, mobility, receptance) and F_s."
MAP_KEYS = ("columns", "preset", "rms", "phase_convention", "phase_unit", "sensitivity",
            "static_load", "sigma", "force_amplitude", "direction", "moving_mass")  # fmt: skip


def parse_columns(text: str | None) -> dict[str, str] | None:
    """``frequency=freq,x=X`` -> ``{"frequency": "freq", "x": "X"}``.

    Raises
    ------
    click.BadParameter
        An item without ``=``.
    """
    if text is None:
        return None
    pairs = {}
    for item in filter(None, (part.strip() for part in text.split(","))):
        quantity, sep, column = item.partition("=")
        if not sep or not quantity.strip() or not column.strip():
            raise click.BadParameter(
                f"expected QUANTITY=COLUMN, got {item!r}", param_hint="--columns"
            )
        pairs[quantity.strip()] = column.strip()
    return pairs


def read_map(path: str) -> dict:
    """The options of a ``--map`` TOML file (its ``[columns]`` table and option keys).

    Raises
    ------
    ConfigError
        Not TOML, or a key that is no option.
    """
    from ..api.runs import read_option_file

    return read_option_file(path, MAP_KEYS)


@cli.command("import")
@click.argument("measured_file", metavar="FILE", type=click.Path(dir_okay=False))
@options.output_option
@click.option("--columns", "columns_text", metavar="Q=COL,...", default=None, help=COLUMNS_HELP)
@click.option(
    "--map", "map_file", metavar="MAP.toml", type=click.Path(dir_okay=False), help=MAP_HELP
)
@click.option("--preset", default=None, type=click.Choice(list(IMPORT_PRESETS)), help=PRESET_HELP)
@click.option("--rms/--peak", default=None, help="A lock-in's values are RMS (default) or peak.")
@click.option(
    "--phase-convention", default=None, type=click.Choice(["lock-in", "spec"]), help=PHASE_HELP
)
@click.option(
    "--phase-unit", default=None, type=click.Choice(["deg", "rad"]), help="The phase column's unit."
)
@click.option(
    "--sensitivity",
    type=float,
    default=None,
    metavar="V_PER_N",
    help="The force transducer's sensitivity [V/N].",
)
@click.option(
    "--static-load", type=float, default=None, metavar="N", help="F_s [N]: newtons to N/F_s."
)
@click.option("--sigma", type=float, default=None, metavar="S", help=LEVEL_HELP)
@click.option("--force-amplitude", type=float, default=None, metavar="N", help=FORCE_HELP)
@click.option(
    "--direction",
    type=click.Choice(["up", "down"]),
    default=None,
    help="The direction of a file of one sweep.",
)
@click.option("--moving-mass", type=float, default=None, metavar="KG", help=MASS_HELP)
@click.option(
    "--rig", "rig_file", type=click.Path(dir_okay=False), default=None, metavar="RIG", help=RIG_HELP
)
def import_command(
    measured_file: str, output: str, columns_text, map_file, rig_file, **values
) -> None:
    """Measurements into a dataset of kind measured, the kind of FILE found from its
    content: hertzsweep's CSV (direction,sigma,frequency,amplitude,phase[,harmonic], or
    direction,sigma,jump_frequency), UFF 58/58b (func_type 4: H1 = N1/F1; func_type 0 with
    func_id k: harmonic k), or a lock-in table (CSV or JSON rows) with --columns, --map or
    --preset. A bad file ends with one line naming the file, the line (or UFF set) and the
    column (or key), exit 2, nothing written."""
    from ..api.runs import import_options, run_import

    inputs = [measured_file, *([map_file] if map_file else []), *([rig_file] if rig_file else [])]
    options.claim_output(output, inputs)
    given = read_map(map_file) if map_file else {}
    columns = {**given.pop("columns", {}), **(parse_columns(columns_text) or {})}
    given.update({key: value for key, value in values.items() if value is not None})
    settings = import_options(rig_file, columns=columns or None, **given)
    options.write_run(run_import(measured_file, settings), output)


@cli.command("export")
@click.argument("input_file", metavar="IN.nc", type=click.Path(exists=True, dir_okay=False))
@options.output_option_for("OUT", "File to write: OUT.uff (UFF 58b or 58) or OUT.csv.")
@click.option(
    "--format",
    "file_format",
    type=click.Choice(["uff58b", "uff58", "csv", "lockin-csv"]),
    default="uff58b",
    show_default=True,
    help="Binary or ASCII UFF 58, hertzsweep's measurement CSV, or lock-in X/Y in volts RMS.",
)
@click.option(
    "--sensitivity",
    type=float,
    default=None,
    metavar="V_PER_N",
    help="For lockin-csv: the transducer's sensitivity [V/N].",
)
@click.option(
    "--static-load",
    type=float,
    default=None,
    metavar="N",
    help="For lockin-csv: F_s [N] (default: the dataset's).",
)
def export_command(
    input_file: str, output: str, file_format: str, sensitivity, static_load
) -> None:
    """A sweep, measured or fit dataset as UFF 58 (H1 an FRF of the transmitted force over
    the excitation force, N1/F1 = A_1 exp(-i phi_1) / sigma; higher harmonics func_type 0
    with the order in func_id; direction in ver_num; sigma in z_axis_value) or as CSV.
    Points not settled, not periodic or not measured are left out and counted."""
    from ..api.runs import export

    options.claim_output(output, (input_file,))
    ds = options.read_dataset(input_file)
    report = export(ds, output, file_format, sensitivity, static_load)
    click.echo(report.line())
    click.echo(f"wrote {output}")


__all__ = ["export_command", "import_command"]
