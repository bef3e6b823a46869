"""GA refinement of the least sensitive coefficients (thesis sections 3.2.3-3.2.4).

1. identify all coefficients by regression (LS or SVM: ``base``);
2. rank them per DOF by Sobol first-order index and take the ``genes_per_dof``
   least sensitive (15 genes; the other 25 stay fixed);
3. evolve the genes with pygad using the thesis settings: the initial
   population is the identified solution plus copies, crossover probability
   0.6, mutation probability 1 (a mutated gene is redrawn within its bounds),
   rank selection, 3 parents kept, gene bounds 0.5-1.5 times the identified
   value (swapped for negative values), 200 generations, stop when the fitness
   reaches 1e-5; the fitness is thesis eq. 3.43 (mean squared u, v, r error
   of the simulated training manoeuvre against the record), evaluated for the
   whole population in one compiled, parallel simulator call.

The refined solution is the best ever evaluated, so it is never worse than
the identified starting solution on the training fitness. Its history is
returned per generation (:attr:`Identification.history`, step = generations
completed, 0 = the starting solution): ``ga/best_fitness``, the best ever
evaluated (non-increasing), and ``ga/population_best_fitness``, the best of
the current population.

References
----------
Gad, A.F. (2023). PyGAD: an intuitive genetic algorithm Python library.
Multimedia Tools and Applications. doi:10.1007/s11042-023-17167-y

Zhu, M. (2021). MSc thesis, NTNU, sections 3.2.3-3.2.4, 4.1.
"""

from __future__ import annotations

import json
import logging
import time

import numpy as np
import pygad

from ..errors import ConfigError
from ..config import GA_BASES
from ..plotting import pyplot
from .base import Identification
from .ls import LeastSquares
from .sensitivity import least_sensitive
from .svm import SupportVectorRegression

__all__ = ["GeneticRefinement", "gene_bounds", "fitness_history", "BASE_METHODS"]

#: regressions that give the GA its starting solution (``base=``)
BASE_METHODS = dict(zip(GA_BASES, (LeastSquares, SupportVectorRegression)))

log = logging.getLogger(__name__)


def gene_bounds(values: np.ndarray, spread: float = 0.5, floor: float = 1e-8):
    """``[low, high]`` per gene: ``(1 -/+ spread) x value``, sign handled.

    A value of exactly zero gets ``[-floor, floor]``.
    """
    values = np.asarray(values, float)
    a = values * (1.0 - spread)
    b = values * (1.0 + spread)
    low = np.minimum(a, b)
    high = np.maximum(a, b)
    zero = values == 0
    low[zero], high[zero] = -floor, floor
    return low, high


class GeneticRefinement:
    """Regression, Sobol gene selection, then pygad on the trajectory fitness.

    Parameters
    ----------
    base : str
        Regression method that gives the starting solution (``ls``, ``svm``;
        :data:`BASE_METHODS`).
    genes_per_dof : int
        Least sensitive coefficients refined per DOF.
    genes : list of str, optional
        Explicit genes instead of the Sobol selection.
    sobol_samples : int
        Base sample size N of the Sobol design.
    generations, population, parents_mating, keep_parents : int
        pygad settings (thesis: 200 generations, identified solution plus 4
        copies, 3 parents kept).
    crossover_probability, mutation_probability : float
    parent_selection : str
    spread : float
        Gene bounds are ``(1 -/+ spread)`` times the identified value.
    stop_fitness : float
        Stop when eq. 3.43 falls to this value.
    seed : int
    """

    name = "ga"

    def __init__(self, base: str = "ls", genes_per_dof: int = 5, genes=None,
                 sobol_samples: int = 5000, generations: int = 200, population: int = 5,
                 parents_mating: int = 4, keep_parents: int = 3,
                 crossover_probability: float = 0.6, mutation_probability: float = 1.0,
                 parent_selection: str = "rank", spread: float = 0.5,
                 stop_fitness: float = 1e-5, seed: int = 0, base_options: dict | None = None):
        self.base = base
        self.genes_per_dof = genes_per_dof
        self.genes = list(genes) if genes else None
        self.sobol_samples = sobol_samples
        self.generations = generations
        self.population = population
        self.parents_mating = parents_mating
        self.keep_parents = keep_parents
        self.crossover_probability = crossover_probability
        self.mutation_probability = mutation_probability
        self.parent_selection = parent_selection
        self.spread = spread
        self.stop_fitness = stop_fitness
        self.seed = seed
        self.base_options = dict(base_options or {})

    def start(self, problems: dict, objective) -> Identification:
        """The regression solution the GA starts from."""
        return self.base_identifier().fit(problems, objective=objective)

    def base_identifier(self):
        """The regression named by ``base`` (:data:`BASE_METHODS`) with ``base_options``."""
        try:
            cls = BASE_METHODS[self.base]
        except KeyError:
            raise ConfigError(f"method '{self.base}' cannot give the GA its starting solution; "
                              f"known: {', '.join(sorted(BASE_METHODS))}") from None
        try:
            return cls(**self.base_options)
        except TypeError as exc:
            raise ConfigError(f"method '{self.base}': {exc}") from None

    def select(self, problems: dict, params: dict):
        """Genes: explicit list, or the least Sobol-sensitive per DOF."""
        if self.genes:
            unknown = set(self.genes) - set(params)
            if unknown:
                raise ValueError(f"GA genes not in the model: {sorted(unknown)}")
            return list(self.genes), None
        return least_sensitive(problems, params, self.genes_per_dof, self.sobol_samples, self.seed)

    def fit(self, problems: dict, objective=None) -> Identification:
        if objective is None:
            raise ValueError("GA refinement needs the trajectory objective of the training records")
        started = self.start(problems, objective)
        model = objective.model
        start = model.vector(started.params)
        genes, table = self.select(problems, started.params)
        gene_idx = np.array([model.names.index(g) for g in genes])
        low, high = gene_bounds(start[gene_idx], self.spread)
        best = {"fitness": np.inf, "vector": start.copy(), "evaluations": 0}
        history = []            # best fitness after each generation
        population_best = []    # (generation, best fitness of its population)

        def full(solutions: np.ndarray) -> np.ndarray:
            vectors = np.repeat(start[None, :], len(solutions), axis=0)
            vectors[:, gene_idx] = solutions
            return vectors

        def fitness_batch(ga, solutions, indices):
            vectors = full(np.atleast_2d(solutions))
            mse = objective.fitness_many(vectors)
            best["evaluations"] += len(mse)
            i = int(np.argmin(mse))
            if mse[i] < best["fitness"]:
                best["fitness"], best["vector"] = float(mse[i]), vectors[i].copy()
            return list(-mse)

        initial_fitness = float(objective.fitness_many(start[None, :])[0])
        best["fitness"], best["vector"] = initial_fitness, start.copy()

        def on_generation(ga):
            history.append(best["fitness"])
            population_best.append((int(ga.generations_completed),
                                    float(-np.max(ga.last_generation_fitness))))
            if ga.generations_completed % 20 == 0 or ga.generations_completed == self.generations:
                log.info("GA generation %d/%d: best fitness %.4g (start %.4g)",
                         ga.generations_completed, self.generations, best["fitness"], initial_fitness)
            if best["fitness"] <= self.stop_fitness:
                return "stop"
            return None

        t0 = time.perf_counter()
        generations_run = 0
        if initial_fitness > self.stop_fitness:
            ga = pygad.GA(
                num_generations=self.generations,
                num_parents_mating=self.parents_mating,
                fitness_func=fitness_batch,
                fitness_batch_size=self.population,
                initial_population=np.repeat(start[gene_idx][None, :], self.population, axis=0),
                gene_space=[{"low": lo, "high": hi} for lo, hi in zip(low, high)],
                parent_selection_type=self.parent_selection,
                keep_parents=self.keep_parents,
                keep_elitism=0,
                crossover_probability=self.crossover_probability,
                mutation_probability=self.mutation_probability,
                on_generation=on_generation,
                random_seed=self.seed,
                suppress_warnings=True,
            )
            ga.run()
            generations_run = int(ga.generations_completed)
            final_population = float(np.min(objective.fitness_many(full(ga.population))))
        else:
            final_population = initial_fitness
            log.info("GA not run: the starting solution already meets the stop fitness")
        elapsed = time.perf_counter() - t0
        params = model.as_dict(best["vector"])
        result = Identification(params=params, metrics=dict(started.metrics))
        result.metrics.update({
            "ga/initial_fitness": initial_fitness,
            "ga/best_fitness": best["fitness"],
            "ga/final_population_best_fitness": final_population,
            "ga/generations": float(generations_run),
            "ga/evaluations": float(best["evaluations"]),
            "ga/n_genes": float(len(genes)),
            "ga/runtime_s": elapsed,
        })
        result.writers["ga_genes.json"] = lambda path: path.write_text(json.dumps(
            {"genes": genes, "low": low.tolist(), "high": high.tolist(),
             "start": start[gene_idx].tolist(), "refined": best["vector"][gene_idx].tolist()},
            indent=1))
        if table is not None:
            result.writers["sobol_indices.csv"] = lambda path: table.to_csv(path)
        if history:
            result.writers["ga_fitness.png"] = lambda path: _plot_history(history, path)
        result.history.update(fitness_history(initial_fitness, history, population_best))
        return result


def fitness_history(initial: float, best: list, population_best: list) -> dict:
    """The GA's step metrics: ``ga/best_fitness`` (thesis eq. 3.43, lower is
    better) at generation 0 (the starting solution) and after each generation,
    and ``ga/population_best_fitness`` of each generation's population.

    Parameters
    ----------
    initial : float
        Fitness of the starting solution.
    best : list of float
        Best fitness ever evaluated after generations 1, 2, ...
    population_best : list of (int, float)
        ``(generation, best fitness of its population)``.
    """
    out = {"ga/best_fitness": [(0, float(initial))] + [(g, float(f)) for g, f in enumerate(best, 1)]}
    if population_best:
        out["ga/population_best_fitness"] = [(0, float(initial))] + list(population_best)
    return out


def _plot_history(history, path) -> None:
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6, 3.5))
    ax.semilogy(np.arange(1, len(history) + 1), history)
    ax.set_xlabel("generation")
    ax.set_ylabel("best fitness (eq. 3.43)")
    ax.set_title("GA refinement")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
