"""harness explore: examples per second and time to find and shrink a planted failure.

Scenarios (tests/explore/data): the demo arm's scripted sweep on its table scene, 1.5 s
episodes at 2 ms, rendering sensors off; ``clear.yaml`` (nothing in range fails: every
example is a generated one) for throughput, ``reach.yaml``'s client program over a range where
nothing fails (its two near targets and the seed: every example a generated one, each running
the client program, started warm: :func:`harness.scenario.warm_clients`), and a planted
failure region of about 2 % of the parameter box (the sweep's ~0.6 m^2 swept band at the
obstacle's height inside a 6 m x 6 m box) for find-and-shrink.

Rows (each measured in this run):

- scripted examples/s with 2 local workers against 1 (target: >= 50/s, the issue's): the
  fast path, warm worlds and the generation kernel (:mod:`harness.explore.kernel`);
- the fast path (``harness explore``) against the cold one (``--cold``: a Session and a
  world compiled for every example), 1 worker;
- examples/s where each example runs the client program, 2 workers (target: >= 5/s), and
  1 worker;
- examples/s with 2 local Dask workers against 1 (one engine per worker);
- seconds to find and shrink the planted 2 % region with 2 workers (target: <= 60 s);
- one passing example's CPU time (its thread's), quiet (:mod:`harness.explore.quiet`) and in
  full (:func:`harness.explore.kernel.run_core`), against its physics alone: 750 bare
  ``mj_step`` calls on the same compiled world (the floor any example pays).

Each rate is examples run over a fixed span of search (``--time``), so the benchmark's length
does not depend on the machine's speed.
"""

from __future__ import annotations

import math
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml
from common import Row

from harness.explore import SearchOptions, load_plan, search

DATA = Path(__file__).resolve().parents[1] / "tests" / "explore" / "data"


def _rate(
    source: Path,
    folder: Path,
    seconds: float,
    workers: int,
    fast: bool = True,
    scheduler: str | None = None,
    failing: bool = False,
) -> float:
    """Examples per second over ``seconds`` of search (--time: generation stops then)."""
    options = SearchOptions(work=folder, examples=100_000, seconds=seconds, workers=workers,
                            fast=fast, seed=11, scheduler=scheduler)  # fmt: skip
    start = time.perf_counter()
    result = search(load_plan(source), options)
    elapsed = time.perf_counter() - start
    assert failing or not result.failures, list(result.failures)
    _ENGINES[:] = [
        (len(o.examples), o.wall_seconds, sum(e.quiet for e in o.examples)) for o in result.outcomes
    ]
    return len(result.examples) / elapsed


_ENGINES: list[tuple[int, float, int]] = []
"""The last :func:`_rate`'s engines: examples, wall seconds, examples run quiet."""


def _engines() -> str:
    """The last rate's engines, each at its own pace (a worker process starts late: its
    imports), and how many examples ran quiet."""
    rates = [n / s for n, s, _ in _ENGINES if s > 0]
    quiet = sum(q for _, _, q in _ENGINES)
    total = sum(n for n, _, _ in _ENGINES)
    each = ", ".join(f"{n} in {s:.1f} s" for n, s, _ in _ENGINES)
    return (
        f"engines {each}: together {sum(rates):.1f} ex/s once all run; "
        f"{quiet} of {total} examples quiet"
    )


def _planted(folder: Path) -> Path:
    doc = yaml.safe_load((DATA / "sweep.yaml").read_text())
    doc["explore"]["parameters"] = {
        "objects.obstacle.position": {"low": [-3.0, -3.0, 0.5], "high": [3.0, 3.0, 0.5]}
    }
    doc["objects"][0]["position"] = [-3.0, -3.0, 0.5]
    path = folder / "planted.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def _reach_clear(folder: Path) -> Path:
    """reach.yaml over a range where nothing fails: TARGET_X 0.1 or 0.2 and the seed (every
    example a generated one, each running the client program)."""
    doc = yaml.safe_load((DATA / "reach.yaml").read_text())
    doc["explore"]["parameters"] = {
        "client.env.TARGET_X": {"choices": ["0.1", "0.2"]},
        "seed": {"integers": [0, 1000]},
    }
    doc["client"]["command"] = f"python {DATA / 'clients' / 'reach.py'} 1.0"
    path = folder / "reach_clear.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def _dask_rates(folder: Path, seconds: float) -> tuple[float, float]:
    import distributed

    rates = []
    for n in (1, 2):
        with distributed.LocalCluster(
            n_workers=0,
            processes=False,
            protocol="tcp://",
            host="127.0.0.1",
            dashboard_address="127.0.0.1:0",
        ) as cluster:
            address = cluster.scheduler_address
            command = [sys.executable, "-m", "distributed.cli.dask_worker", address, "--host",
                       "127.0.0.1", "--nthreads", "1", "--no-nanny", "--no-dashboard"]  # fmt: skip
            workers = [
                subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                for _ in range(n)
            ]
            try:
                with distributed.Client(address) as client:
                    client.wait_for_workers(n, timeout=120)
                _rate(DATA / "clear.yaml", folder / f"warm{n}", 0.5, n, scheduler=address)
                rates.append(
                    _rate(DATA / "clear.yaml", folder / f"dask{n}", seconds, n, scheduler=address)
                )
            finally:
                for w in workers:
                    w.terminate()
                    w.wait(timeout=30)
    return rates[0], rates[1]


def _example_cpu(reps: int) -> tuple[float, float, float]:
    """Thread CPU seconds (best of ``reps``) of one passing clear.yaml example quiet, in
    full, and of its 750 bare ``mj_step`` calls."""
    import mujoco

    from harness.explore.kernel import run_core
    from harness.explore.parameters import apply_values
    from harness.explore.quiet import quiet_run
    from harness.explore.warm import WarmWorlds
    from harness.scenario import Scenario

    plan = load_plan(DATA / "clear.yaml")
    nominal = {p.path: p.nominal for p in plan.parameters}
    document = apply_values(plan.document, plan.parameters, nominal)
    scenario = Scenario.from_mapping(document, base_dir=plan.source.parent, source=plan.source)
    with tempfile.TemporaryDirectory() as tmp:
        planned, world, timestep = WarmWorlds(Path(tmp)).get(scenario, document)
        allowed = tuple(scenario.criteria.allowed_collisions)
        steps = round(scenario.duration / timestep)

        def bare() -> None:
            model, data = world.model, mujoco.MjData(world.model)
            for _ in range(steps):
                mujoco.mj_step(model, data)

        def quiet() -> None:
            assert quiet_run(scenario, planned, world, timestep, allowed) is not None

        def full() -> None:
            run_core(scenario, planned, world, timestep, allowed)

        out = []
        for fn in (quiet, full, bare):
            fn()
            best = math.inf
            for _ in range(reps):
                start = time.thread_time()
                fn()
                best = min(best, time.thread_time() - start)
            out.append(best)
    return out[0], out[1], out[2]


def run(quick: bool) -> list[Row]:
    span = 8.0 if quick else 30.0  # seconds of search per rate
    budget = 30.0 if quick else 60.0  # the planted failure's --time
    rows: list[Row] = []
    quiet, full, bare = _example_cpu(5 if quick else 20)
    rows.append(Row(
        name="explore: one passing example (clear.yaml, 750 steps), quiet vs its bare mj_step",
        ours=quiet * 1e3, limit=bare * 1e3, unit="ms CPU", target="(no target; the floor)",
        passed=True, higher_is_better=False,
        note=f"in full (every logger every step) {full * 1e3:.1f} ms; "
        f"quiet {quiet * 1e3:.1f} ms; 750 bare mj_step {bare * 1e3:.1f} ms",
    ))  # fmt: skip
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        clear = DATA / "clear.yaml"
        _rate(clear, folder / "warm", 0.5, 1)  # imports, first world
        one = _rate(clear, folder / "one", span, 1)
        two = _rate(clear, folder / "two", span, 2)
        rows.append(Row(
            name=f"explore scripted (1.5 s episodes): {span:g} s of search, 2 vs 1 worker",
            ours=two, limit=one, unit="ex/s", target="2 workers >= 50 ex/s",
            passed=two >= 50,
            note=f"1 worker {one:.2f} ex/s, 2 workers {two:.2f} ex/s; 2 workers' {_engines()}",
        ))  # fmt: skip
        cold = _rate(clear, folder / "cold", span, 1, fast=False)
        rows.append(Row(
            name=f"explore scripted: fast path vs cold (--cold), 1 worker, {span:g} s",
            ours=one, limit=cold, unit="ex/s", target="ratio >= 1",
            passed=one >= cold, note=f"cold {cold:.2f} ex/s",
        ))  # fmt: skip
        reach = _reach_clear(folder)
        client1 = _rate(reach, folder / "client1", span, 1)
        client2 = _rate(reach, folder / "client2", span, 2)
        rows.append(Row(
            name=f"explore with a client program per example (warm): {span:g} s, 2 workers",
            ours=client2, limit=5.0, unit="ex/s", target="2 workers >= 5 ex/s",
            passed=client2 >= 5.0, note=f"1 worker {client1:.2f} ex/s",
        ))  # fmt: skip
        d1, d2 = _dask_rates(folder, span)
        rows.append(Row(
            name=f"explore --backend dask: {span:g} s, 2 vs 1 local Dask worker",
            ours=d2, limit=d1, unit="ex/s", target="ratio >= 1.5",
            passed=d2 >= 1.5 * d1, note=f"1 worker {d1:.2f} ex/s, 2 workers {d2:.2f} ex/s",
        ))  # fmt: skip
        planted = _planted(folder)
        start = time.perf_counter()
        result = search(
            load_plan(planted),
            SearchOptions(work=folder / "planted", examples=100_000, seconds=budget, workers=2,
                          seed=5),
        )  # fmt: skip
        found = time.perf_counter() - start
        ok = bool(result.failures)
        rows.append(Row(
            name="explore: planted ~2 % failure region found and shrunk, 2 workers",
            ours=found if ok else float("inf"), limit=60.0, unit="s", target="<= 60 s",
            passed=ok and found <= 60.0, higher_is_better=False,
            note=f"{len(result.examples)} examples ({result.generated} generated); "
            + ("found: " + next(iter(result.failures)) if ok else "not found in the budget"),
        ))  # fmt: skip
    return rows
