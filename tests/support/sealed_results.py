"""Small sealed result files of every kind, for the validation tests and the fuzz tier.

Made with today's runners (:func:`study.engine.runner.run_study`,
:func:`study.engine.runner.run_scene`),
then sealed with :func:`study.engine.validation.seal`, as the streaming writer does.
"""

from __future__ import annotations

import re
from pathlib import Path

from study.engine.runner import run_scene, run_study
from study.engine.validation import seal

WORKFLOWS = Path(__file__).resolve().parents[2] / "workflows"

_STRUCTURE = """
[structure]
f0 = 14.44   # Hz
Q = 17.5
alpha = 64.0 # degree
M = 0.08
cs = 0.25
"""

STUDIES = {
    # 4 x 3 points: static, stick-slip and lift-off points, with diagnostics.
    "velocity": """
[study]
name = "velocity"
title = "A 4 x 3 velocity study with diagnostics"
observables = ["velocity", "diagnostics"]
""" + _STRUCTURE + """
[sweep]
f = { start = 10.0, stop = 20.0, num = 4 }  # Hz
a = { start = 0.0, stop = 12.0, num = 3 }   # m s-2
""",
    # Closed forms over f only: no a axis.
    "thresholds": """
[study]
name = "thresholds"
title = "Thresholds only"
observables = ["thresholds"]
""" + _STRUCTURE + """
[sweep]
f = { start = 8.0, stop = 20.0, num = 5 }  # Hz
""",
    # A structure axis: every point variable is over (Q, f, a).
    "swept-q": """
[study]
name = "swept-q"
title = "Velocity for two quality factors"
observables = ["velocity", "lift_off"]
""" + _STRUCTURE.replace("Q = 17.5\n", "") + """
[sweep]
Q = { values = [15.0, 30.0] }
f = { start = 12.0, stop = 16.0, num = 3 }  # Hz
a = { start = 0.0, stop = 12.0, num = 3 }   # m s-2
""",
}


def scene_text() -> str:
    """``workflows/steering.toml`` with 0.5 s segments sampled every 0.1 s."""
    text = (WORKFLOWS / "steering.toml").read_text()
    text = re.sub(r"duration = [0-9.]+", "duration = 0.5", text)
    return re.sub(r"sample_interval = [0-9.]+", "sample_interval = 0.1", text)


def make_sealed_results(folder: Path) -> dict[str, Path]:
    """Write and seal the three studies and the scene in ``folder``: name -> file."""
    files = {}
    for name, text in STUDIES.items():
        spec = folder / f"{name}.toml"
        spec.write_text(text)
        files[name] = run_study(spec, folder / f"{name}.nc", progress=False, workers=1).output
    spec = folder / "steering.toml"
    spec.write_text(scene_text())
    files["steering"] = run_scene(spec, folder / "steering.nc").output
    for path in files.values():
        seal(path)
    return files


def rewrite(source: Path, target: Path, *, drop: tuple[str, ...] = (),
            transpose: dict[str, tuple[int, ...]] | None = None,
            dtypes: dict[str, str] | None = None,
            rename_dims: dict[str, str] | None = None, compress: bool = False) -> Path:
    """Copy a netCDF file variable by variable with netCDF4, changing what is asked.

    Parameters
    ----------
    drop : names of variables left out.
    transpose : name -> axis order of a variable (its values and dimensions).
    dtypes : name -> new numpy dtype of a variable (its values are cast).
    rename_dims : old -> new dimension name.
    compress : store every variable of 1 dimension or more deflated (a storage change
        only: the content checksum does not see it).
    """
    import netCDF4
    import numpy as np

    transpose = transpose or {}
    dtypes = dtypes or {}
    rename_dims = rename_dims or {}
    with netCDF4.Dataset(source) as src, netCDF4.Dataset(target, "w") as dst:
        src.set_auto_maskandscale(False)
        src.set_auto_chartostring(False)
        dst.setncatts({k: src.getncattr(k) for k in src.ncattrs()})
        for name, dim in src.dimensions.items():
            dst.createDimension(rename_dims.get(name, name), len(dim))
        for name, var in src.variables.items():
            if name in drop:
                continue
            dims = tuple(rename_dims.get(d, d) for d in var.dimensions)
            data = var[...]
            if name in transpose:
                data = np.transpose(data, transpose[name])
                dims = tuple(dims[i] for i in transpose[name])
            attrs = {k: var.getncattr(k) for k in var.ncattrs()}
            fill = attrs.pop("_FillValue", None)
            dtype = str if var.dtype is str else np.dtype(dtypes.get(name, var.dtype))
            if fill is not None and dtype is not str:
                # A NaN fill value has no integer form: integers get none.
                fill = None if dtype.kind in "iu" else np.asarray(fill).astype(dtype)
            options = {"zlib": True, "complevel": 4} if compress and dims else {}
            new = dst.createVariable(name, dtype, dims, fill_value=fill, **options)
            new.set_auto_maskandscale(False)
            new.setncatts(attrs)
            if dtype is str:
                new[...] = np.asarray(data, dtype=object)
            else:
                with np.errstate(invalid="ignore", over="ignore"):  # NaN or huge -> int
                    new[...] = np.asarray(data).astype(dtype)
    return target
