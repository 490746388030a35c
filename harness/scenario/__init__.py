"""Scenarios and the runner: scenario files (a superset of the original scene config), runner
configs (the original ``sim_runner`` format), iterations on local or Dask workers, and reports
(JUnit XML, JSON, self-contained HTML).

The runner machinery talks to whatever runs one iteration through :class:`IterationRunner`;
:func:`session_iteration_runner` returns the session-backed one
(:mod:`harness.scenario.session_runner`, imported when used).
"""

from harness.scenario._validation import validator as schema_validator
from harness.scenario.bundle import BlobStore, Bundle, bundle_env, collect_bundle, mirror
from harness.scenario.client import BridgeHost, run_client, stop_group
from harness.scenario.client_warm import WarmPool, warm_clients
from harness.scenario.dask_backend import (
    BLOB_KEY_PREFIX,
    DaskBackend,
    unverified_blobs,
    verified_tree,
    worker_dir,
)
from harness.scenario.errors import RunnerError, ScenarioError
from harness.scenario.execute import run_scenarios
from harness.scenario.reports import render_html, write_reports
from harness.scenario.results import (
    ClientOutcome,
    CollisionSummary,
    IterationResult,
    IterationRunner,
    IterationSpec,
    JointLimitSummary,
    JointTrace,
    Traces,
    Verdict,
    criteria_settings,
    judge,
)
from harness.scenario.runfile import RunConfig, SimulationPlan, load_run_file
from harness.scenario.runner import (
    Backend,
    LocalBackend,
    check_runnable,
    iteration_specs,
    judge_determinism,
    run_iterations,
    session_iteration_runner,
)
from harness.scenario.scenario import (
    BUILTIN_MAPS,
    BUILTIN_ROBOTS,
    ClientSpec,
    Clock,
    Criteria,
    Scenario,
    ScenarioRobot,
)
from harness.scenario.script import ScriptCommand, run_script
from harness.scenario.session_options import ScenarioSession, scenario_session
from harness.scenario.session_runner import _collisions as collision_summaries
from harness.scenario.session_runner import _Observer as IterationObserver
from harness.scenario.session_runner import (
    check_script,
    robot_links,
    run_verdicts,
    sink_notes,
    steps_for,
)
from harness.scenario.travel import travel_verdict
from harness.scenario.world import effective_timestep, robot_pose

__all__ = [
    "BLOB_KEY_PREFIX",
    "BUILTIN_MAPS",
    "BUILTIN_ROBOTS",
    "Backend",
    "BlobStore",
    "BridgeHost",
    "Bundle",
    "ClientOutcome",
    "ClientSpec",
    "Clock",
    "CollisionSummary",
    "Criteria",
    "DaskBackend",
    "IterationObserver",
    "IterationResult",
    "IterationRunner",
    "IterationSpec",
    "JointLimitSummary",
    "JointTrace",
    "LocalBackend",
    "RunConfig",
    "RunnerError",
    "Scenario",
    "ScenarioError",
    "ScenarioRobot",
    "ScenarioSession",
    "ScriptCommand",
    "SimulationPlan",
    "Traces",
    "Verdict",
    "WarmPool",
    "bundle_env",
    "check_runnable",
    "check_script",
    "collect_bundle",
    "collision_summaries",
    "criteria_settings",
    "effective_timestep",
    "iteration_specs",
    "judge",
    "judge_determinism",
    "load_run_file",
    "mirror",
    "render_html",
    "robot_links",
    "robot_pose",
    "run_client",
    "run_iterations",
    "run_scenarios",
    "run_script",
    "run_verdicts",
    "scenario_session",
    "schema_validator",
    "session_iteration_runner",
    "sink_notes",
    "steps_for",
    "stop_group",
    "travel_verdict",
    "unverified_blobs",
    "verified_tree",
    "warm_clients",
    "worker_dir",
    "write_reports",
]
