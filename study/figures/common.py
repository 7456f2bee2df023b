"""What every figure shares: style, saving as PNG and PDF, provenance in the metadata."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import xarray as xr

__all__ = ["provenance_line", "save", "structure_from_dataset"]


def provenance_line(dataset: xr.Dataset) -> str:
    """One line naming the data a figure came from (study, spec hash, fingerprint)."""
    attrs = dataset.attrs
    return (
        f"data: study '{attrs.get('study_name')}', spec sha256 "
        f"{attrs.get('study_spec_sha256', '?')}, fingerprint "
        f"{attrs.get('study_fingerprint', '?')}, created {attrs.get('date_created', '?')} "
        f"by study {attrs.get('study_version', '?')}"
    )


def save(fig: plt.Figure, output: str | Path, dataset: xr.Dataset, title: str) -> list[Path]:
    """Write ``output.png`` and ``output.pdf`` with the data's provenance in their metadata.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure (closed afterwards).
    output : path
        File stem; a ``.png``/``.pdf`` suffix is replaced.
    dataset : xarray.Dataset
        The result file's dataset the figure was drawn from.
    title : str
        What the figure shows (also its metadata title).

    Returns
    -------
    list of pathlib.Path
        The PNG and the PDF.
    """
    stem = Path(output)
    if stem.suffix in (".png", ".pdf"):
        stem = stem.with_suffix("")
    stem.parent.mkdir(parents=True, exist_ok=True)
    source = provenance_line(dataset)
    written = []
    png = stem.with_suffix(".png")
    fig.savefig(png, dpi=150, metadata={
        "Title": title,
        "Description": source,
        "Source": f"study_spec_sha256={dataset.attrs.get('study_spec_sha256', '')}",
        "Software": f"study {dataset.attrs.get('study_version', '')}",
    })
    written.append(png)
    pdf = stem.with_suffix(".pdf")
    fig.savefig(pdf, metadata={
        "Title": title,
        "Subject": source,
        "Keywords": f"study_spec_sha256={dataset.attrs.get('study_spec_sha256', '')}",
        "Creator": f"study {dataset.attrs.get('study_version', '')}",
    })
    written.append(pdf)
    plt.close(fig)
    return written


def structure_from_dataset(dataset: xr.Dataset, **at: int):
    """The :class:`study.Structure` a result was computed for.

    Fixed parameters come from the file's scalar coordinates; for a swept one give
    its index, e.g. ``structure_from_dataset(ds, M=3)`` (``m_add`` for mass studies).
    """
    import study

    params = {}
    for name in ("f0", "Q", "alpha", "M", "cs", "ck", "g"):
        if name in dataset.coords and dataset[name].ndim == 0:
            params[name] = float(dataset[name])
    for name, index in at.items():
        params[name] = float(dataset[name].values[index])
        if name == "m_add":
            params["M"] = float(dataset["M"].values[index])
            del params["m_add"]
    if "ck" not in params and "cs" in params:
        params["ck"] = params["cs"]
    return study.Structure(**params)
