"""The learning loop as a benchmark: expert demonstrations -> LeRobot v3 export -> a LeRobot ACT policy trained
on the CPU with LeRobot's own `lerobot-train` -> `rio eval` of the checkpoint (`lerobot.local`) on held-out
starts -> a paper-style table. Outside CI: it needs torch and lerobot, which it installs itself.

    uv run --no-sync python bench/learning_loop.py                  # the whole loop (~45 min on 2 cores)
    uv run --no-sync python bench/learning_loop.py --train-minutes 5 --trials 4  # a quick look

Stages, each kept under --work and reused when its output is there (delete it, or --fresh, to redo it):
1. 50 demonstrations of sim-so100's task by the scripted expert (`rio_sim.expert_demos`: the rows
   `rio teleop sim-so100 --teleop expert --record` writes, faster than real time, no cameras), seeds (0, k);
2. `rio export --format lerobot`: observation.state (joints + gripper), observation.environment_state (the
   objects' poses), action; no video, so LeRobot's video decoding is never needed;
3. the training environment under --cache (made once, reused): a venv with pip's torch 2.14.1 and torchvision
   0.29.1 (pip takes the wheels this machine keeps on disk; uv does not look there), then lerobot 0.4.4 by
   `uv pip` with overrides keeping that torch (lerobot asks for torch<2.11, which pip cannot override), then this
   workspace's rio-core,
   rio-sim and rio-policies (editable) so `rio eval` runs there and loads the checkpoint;
4. `lerobot-train` (ACT on state + environment state; no VAE: the expert is deterministic) with one torch
   thread (on a loaded 2-core machine two threads spin against each other and run ~20x slower) and a
   wall-clock budget: the run is stopped at --train-minutes and the last saved checkpoint is the policy;
5. `rio eval` of that checkpoint (`lerobot.local,...,rate_hz=30`) on --trials starts of seed 1, which no
   demonstration used, on the same station as the demonstrations (sim-so100 without cameras, 15 s limit).

The table: policy, inputs, demonstrations, training (steps, wall time), success over the trials, and the mean
completion time of the successes against the demonstrations' (task time to the success that held).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: the packaged station: sim-so100 (its scene, arm, gripper and task starts) without cameras or teleop device,
#: 15 s per trial
STATION = "sim-so100-loop"

#: torch and torchvision that pip takes from this machine's disk and that import together (PyPI's torchvision 0.28
#: beside the CPU torch 2.13.0 fails: its extension links the CUDA libraries, `torchvision::nms does not exist`);
#: torch 2.14.1 is a CUDA build, run here on the CPU
TORCH = ["torch==2.14.1", "torchvision==0.29.1"]
LEROBOT = "lerobot==0.4.4"
#: lerobot 0.4.4 asks for torch<2.11: keep the torch installed above
OVERRIDES = TORCH
#: ACT sized for a CPU: a 128-wide transformer (1 M parameters instead of the default 40 M)
ACT = ["--policy.type=act", "--policy.use_vae=false", "--policy.dim_model=128", "--policy.dim_feedforward=512",
       "--policy.n_heads=4", "--policy.n_encoder_layers=2", "--policy.n_decoder_layers=1"]


def log(msg: str) -> None:
    print(f"[{time.strftime('%H:%M:%S')}] {msg}", file=sys.stderr, flush=True)


def single_thread_env() -> dict[str, str]:
    return {**os.environ, "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "HF_HUB_OFFLINE": "1",
            "HF_DATASETS_OFFLINE": "1", "WANDB_MODE": "disabled"}


def record(work: Path, station: str, demos: int, seed: int) -> dict:
    """The expert's demonstrations (kept: the successful ones) and their completion times."""
    out, meta = work / "demos", work / "demos.json"
    if meta.exists() and out.exists():
        return json.loads(meta.read_text())
    from rio_sim.expert import HOLD_S
    from rio_sim.expert_demos import record_expert_demos

    shutil.rmtree(out, ignore_errors=True)
    log(f"recording {demos} expert demonstrations (seed {seed})")
    rollouts = record_expert_demos(out, station, episodes=range(demos), seed=seed)
    times = [r.time_s - HOLD_S for r in rollouts if r.success]
    info = {"episodes": demos, "kept": len(times), "seed": seed, "completion_s": times}
    meta.write_text(json.dumps(info))
    return info


def export(work: Path) -> Path:
    out = work / "lerobot"
    if not (out / "meta" / "info.json").exists():
        log("exporting to LeRobot v3")
        shutil.rmtree(out, ignore_errors=True)
        subprocess.run([sys.executable, "-m", "rio", "export", str(work / "demos"), "--format", "lerobot", str(out),
                        "-o", "task=put the red cube on the blue pad", "-o", "extra_observations=false"],
                       check=True)
    return out


def training_env(cache: Path) -> Path:
    """The venv with CPU torch, lerobot and this workspace's rio (made once under `cache`, then reused)."""
    venv = cache / "venv"
    py = venv / "bin" / "python"
    if (venv / ".complete").exists():
        if not runs_this_workspace(py):  # made from another checkout (since moved or deleted): install this one
            log("the training environment's rio is another checkout's: installing this one's")
            install_workspace(py, cache)
        return py
    shutil.rmtree(venv, ignore_errors=True)  # a half-made one (no .complete): made again
    cache.mkdir(parents=True, exist_ok=True)
    log(f"making the training environment in {venv} (once; minutes)")
    base = sys.executable if sys.prefix == sys.base_prefix else getattr(sys, "_base_executable", sys.executable)
    subprocess.run([base, "-m", "venv", str(venv)], check=True)
    subprocess.run([str(py), "-m", "pip", "install", "--quiet", "--upgrade", "pip"], check=True)
    subprocess.run([str(py), "-m", "pip", "install", "--quiet", *TORCH], check=True)  # pip takes the wheels on disk
    # lerobot 0.4.4 asks for torch<2.11: uv's overrides keep the torch just installed (pip cannot override)
    subprocess.run([*uv_install(py, cache), LEROBOT], check=True)
    install_workspace(py, cache)
    check = "import torchvision.ops, lerobot.scripts.lerobot_train, rio_policies, rio_sim"
    subprocess.run([str(py), "-c", check], check=True)
    (venv / ".complete").touch()
    return py


def uv_install(py: Path, cache: Path) -> list[str]:
    """`uv pip install` into the training environment, with overrides keeping its torch."""
    overrides = cache / "overrides.txt"
    overrides.write_text("\n".join(OVERRIDES) + "\n")
    return [shutil.which("uv") or "uv", "pip", "install", "--python", str(py), "--overrides", str(overrides)]


def install_workspace(py: Path, cache: Path) -> None:
    """This checkout's rio-core, rio-sim and rio-policies, editable: `rio eval` runs there on this code."""
    subprocess.run([*uv_install(py, cache), "-e", str(ROOT / "rio-core"), "-e", str(ROOT / "plugins" / "rio-sim"),
                    "-e", str(ROOT / "plugins" / "rio-policies")], check=True)


def runs_this_workspace(py: Path) -> bool:
    """Whether the environment's rio, rio_sim and rio_policies are this checkout's."""
    where = subprocess.run([str(py), "-c", "import rio, rio_sim, rio_policies; "
                                           "print(rio.__file__, rio_sim.__file__, rio_policies.__file__)"],
                           capture_output=True, text=True)
    return where.returncode == 0 and all(Path(f).resolve().is_relative_to(ROOT) for f in where.stdout.split())


def complete_checkpoints(run: Path) -> list[Path]:
    """Saved checkpoints whose pretrained_model is whole (a run stopped mid-save leaves one that is not)."""
    need = ("config.json", "model.safetensors", "policy_preprocessor.json", "policy_postprocessor.json")
    out = []
    for d in sorted((run / "checkpoints").glob("[0-9]*")):
        m = d / "pretrained_model"
        if all((m / f).exists() for f in need):
            out.append(m)
    return out


def train(py: Path, dataset: Path, work: Path, steps: int, minutes: float, batch: int, chunk: int, lr: float,
          save_every: int) -> dict:
    """lerobot-train, stopped at `minutes` of wall time; the last whole checkpoint and how it was reached."""
    meta = work / "train.json"
    if meta.exists():
        return json.loads(meta.read_text())
    run = work / "act"
    shutil.rmtree(run, ignore_errors=True)
    cmd = [str(py.parent / "lerobot-train"), "--dataset.repo_id=local/sim_so100_pick", f"--dataset.root={dataset}",
           *ACT, f"--policy.optimizer_lr={lr}", f"--policy.chunk_size={chunk}", f"--policy.n_action_steps={chunk}",
           "--policy.device=cpu",
           "--policy.push_to_hub=false", f"--output_dir={run}", "--job_name=act_sim_so100", f"--steps={steps}",
           f"--batch_size={batch}", "--num_workers=1", "--log_freq=100", f"--save_freq={save_every}",
           "--eval_freq=0", "--wandb.enable=false", "--seed=1000"]
    log("training: " + " ".join(cmd))
    logfile = work / "train.log"
    t0 = time.monotonic()
    with logfile.open("w") as f:
        proc = subprocess.Popen(cmd, stdout=f, stderr=subprocess.STDOUT, env=single_thread_env(),
                                start_new_session=True)
        try:
            rc = proc.wait(timeout=minutes * 60)
        except subprocess.TimeoutExpired:
            log(f"training budget ({minutes:g} min) reached: stopping lerobot-train, keeping its last checkpoint")
            os.killpg(proc.pid, signal.SIGTERM)
            rc = proc.wait()
    wall = time.monotonic() - t0
    done = complete_checkpoints(run)
    if not done:
        raise SystemExit(f"lerobot-train saved no whole checkpoint in {wall:.0f} s (rc {rc}): see {logfile}")
    info = {"checkpoint": str(done[-1]), "steps": int(done[-1].parent.name), "wall_s": wall,
            "batch": batch, "chunk": chunk, "lr": lr, "flags": ACT, "cores": os.cpu_count(),
            "load_1min": os.getloadavg()[0]}
    meta.write_text(json.dumps(info))
    return info


def evaluate(py: Path, station: str, checkpoint: str, trials: int, seed: int, work: Path) -> dict:
    meta = work / "eval.json"
    if meta.exists():
        return eval_json(meta.read_text())
    policy = f"lerobot.local,path={checkpoint},rate_hz=30"
    cmd = [str(py.parent / "rio"), "eval", station, "--policy", policy, "--trials", str(trials),
           "--seed", str(seed), "--json"]
    log("evaluating: " + " ".join(cmd))
    out = subprocess.run(cmd, capture_output=True, text=True, env=single_thread_env())
    if out.returncode != 0:
        raise SystemExit(f"rio eval failed (rc {out.returncode}):\n{out.stderr[-4000:]}")
    meta.write_text(out.stdout)
    return eval_json(out.stdout)


def eval_json(text: str) -> dict:
    """`rio eval --json`'s object (from its first line that opens one: a library may have printed before it)."""
    lines = text.splitlines()
    start = next((i for i, line in enumerate(lines) if line.startswith("{")), 0)
    return json.loads("\n".join(lines[start:]))


def table(demos: dict, trained: dict, result: dict, trials: int) -> str:
    import numpy as np

    ok = [t for t in result["trials"] if t["success"]]
    demo_mean = float(np.mean(demos["completion_s"]))
    mean = f"{np.mean([t['time_s'] for t in ok]):.2f} s" if ok else "-"
    rows = [("policy", "inputs", "demos", "training", "success", "mean completion (demos)"),
            ("ACT (LeRobot 0.4.4)", "state + env. state", str(demos["kept"]),
             f"{trained['steps']} steps, {trained['wall_s'] / 60:.1f} min",
             f"{len(ok)}/{trials} ({100 * len(ok) / trials:.0f}%)", f"{mean} ({demo_mean:.2f} s)")]
    w = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    lines = ["| " + " | ".join(c.ljust(w[i]) for i, c in enumerate(r)) + " |" for r in rows]
    lines.insert(1, "|" + "|".join("-" * (x + 2) for x in w) + "|")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--work", type=Path, default=Path("outputs/learning_loop"),
                    help="where each stage's output is kept")
    ap.add_argument("--cache", type=Path, default=Path.home() / ".cache" / "rio" / "learning-loop",
                    help="where the training environment is made (once)")
    ap.add_argument("--fresh", action="store_true", help="redo every stage but the environment")
    ap.add_argument("--demos", type=int, default=50)
    ap.add_argument("--demo-seed", type=int, default=0)
    ap.add_argument("--eval-seed", type=int, default=1, help="held out: differs from --demo-seed")
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--steps", type=int, default=200000, help="lerobot-train's --steps (the time budget stops first)")
    ap.add_argument("--train-minutes", type=float, default=30.0, help="wall-clock training budget")
    ap.add_argument("--save-every", type=int, default=250, help="checkpoint period in steps")
    ap.add_argument("--batch", type=int, default=32)
    ap.add_argument("--chunk", type=int, default=20, help="ACT chunk size (actions per inference, 30 fps)")
    ap.add_argument("--lr", type=float, default=1e-4, help="ACT's learning rate (its backbone has none: no images)")
    a = ap.parse_args()
    if a.eval_seed == a.demo_seed:
        ap.error("--eval-seed must differ from --demo-seed: the evaluation's starts are held out")
    work = a.work.resolve()
    if a.fresh:
        shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True, exist_ok=True)
    demos = record(work, STATION, a.demos, a.demo_seed)
    dataset = export(work)
    py = training_env(a.cache.resolve())
    trained = train(py, dataset, work, a.steps, a.train_minutes, a.batch, a.chunk, a.lr, a.save_every)
    result = evaluate(py, STATION, trained["checkpoint"], a.trials, a.eval_seed, work)
    print(table(demos, trained, result, a.trials))
    print(f"\nmachine: {os.cpu_count()} cores, load average at the end of training {trained['load_1min']:.1f}; "
          f"demonstrations seed {a.demo_seed}, evaluation seed {a.eval_seed}; checkpoint {trained['checkpoint']}")


if __name__ == "__main__":
    main()
