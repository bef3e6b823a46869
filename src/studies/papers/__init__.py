"""The published values of the papers `studies` is built from, entered once as data.

Each paper has an id (the ``report.compare=`` value of ``studies report``), its
citation, and its tables as CSV files beside this module, every row naming
the table (and the page where the paper has page numbers, else its section)
it was read from.
The reproduction reports (:mod:`studies.report.reproduction`) put these
numbers beside the project's own.

The values were read from the plain-text copies of the papers; where a cell
was garbled in the copy, the table's own text (which often repeats the
number) was used, and the file's header says so.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from ..errors import ConfigError

__all__ = ["Paper", "PAPERS", "get_paper", "published"]

DATA = Path(__file__).resolve().parent


@dataclass(frozen=True)
class Paper:
    """One paper: its id, citation and the files of its published tables.

    Attributes
    ----------
    id : str
        ``report.compare=`` value (``thesis``, ``svm_paper``, ``roll_paper``).
    citation : str
    tables : dict
        ``{name: file}``: CSV files in this folder (``#`` lines are comments).
    """

    id: str
    citation: str
    tables: dict = field(default_factory=dict)


PAPERS = {
    "thesis": Paper(
        "thesis",
        "M. Zhu (2021), Genetic-algorithm-based parameter identification for ship manoeuvring "
        "model under wind disturbance, MSc thesis, NTNU",
        {"deviations": "zhu2021_deviations.csv", "calm": "zhu2021_calm.csv"}),
    "roll_paper": Paper(
        "roll_paper",
        "C. Chen, M. Tello Ruiz, G. Delefortrie, T. Mei, M. Vantorre, E. Lataire (2019), Parameter "
        "estimation for a ship's roll response model in shallow water using an intelligent machine "
        "learning method, Ocean Engineering 191, 106479",
        {"tables": "chen2019.csv"}),
    "svm_paper": Paper(
        "svm_paper",
        "T. Wang, G. Li, B. Wu, V. Aesoy, H. Zhang (2021), Parameter identification of ship manoeuvring "
        "model under disturbance using support vector machine method, Ships and Offshore Structures "
        "16(S1), 13-21",
        {"table4": "wang2021_table4.csv", "table1": "wang2021_table1.csv"}),
    "li2023": Paper(
        "li2023",
        "S. Li, T. Wang, G. Li, H. Zhang (2023), Ship maneuvering model optimization for improved "
        "identification with less excitation, Ocean Engineering 280, 114540",
        {"tables": "li2023.csv"}),
    "alexandersson2022": Paper(
        "alexandersson2022",
        "M. Alexandersson, W. Mao, J.W. Ringsberg (2022), System identification of vessel manoeuvring "
        "models, Ocean Engineering 266, 112940",
        {"turning_circles": "alexandersson2022.csv"}),
}


def get_paper(paper_id: str) -> Paper:
    """The paper registered under ``paper_id``; ``ConfigError`` names the known ones."""
    try:
        return PAPERS[paper_id]
    except KeyError:
        raise ConfigError(f"report.compare: unknown paper '{paper_id}'; known: "
                          f"{', '.join(sorted(PAPERS))}") from None


def published(paper_id: str, table: str) -> pd.DataFrame:
    """A paper's published table (:attr:`Paper.tables`) as a DataFrame (the
    ``table`` column, the paper's table number, as text: "4.10" is not 4.1)."""
    paper = get_paper(paper_id)
    try:
        name = paper.tables[table]
    except KeyError:
        raise ConfigError(f"paper '{paper_id}' has no table '{table}'; it has "
                          f"{', '.join(sorted(paper.tables))}") from None
    return pd.read_csv(DATA / name, comment="#", dtype={"table": str})
