"""Training across processes and machines on Ray: rollout workers feeding one learner.

``RayTrainer`` is :class:`~tumble.rl.train.Trainer` with its samples collected by K Ray
actors (:class:`RolloutWorker`), each stepping its own batch of ``config.num_envs`` worlds
(``World(nworld=N)``), while the learner (this process) keeps rsl-rl's PPO, the AMP
discriminator, the checkpoints, the logs and the evaluations exactly as a single-process
run does. An iteration:

1. the learner sends every worker the actor's and critic's weights (and the
   discriminator's, for AMP) and a state of torch's random generator;
2. each worker runs the same rollout code as the single-process trainer
   (``collect_rollout``: rsl-rl's ``act`` and ``process_env_step`` on its worlds) and
   returns its rollout storage (observations, actions, rewards, values, log-probabilities,
   distribution parameters), its last observations, the AMP transitions and its statistics;
3. the learner stacks them along the world axis into its own storage, computes the
   returns and runs PPO's update (and the discriminator's).

Worker 0 receives the learner's generator state and hands back where it left it, so with
one worker a seeded run repeats the single-process trainer's bit for bit (same worlds, same
seed, same threads); the other workers draw from states derived from the seed and the
iteration. Why Ray actors around rsl-rl rather than RLlib's PPO: the learner, its
checkpoints and the exported policy stay those of the single-process trainer (one code path,
tested once), a worker's rollout is a whole batch of worlds in one call (RLlib's env runners
step a Gymnasium VectorEnv through its connector pipeline per step), and RLlib adds a large
dependency that the core does not need. bench/bench_ray.py measures the cost.

Faults. A worker that dies (its process killed, its machine lost) is replaced by a new
actor with fresh worlds and its rollout asked again; training goes on from the learner's
state and loses only the samples that were in flight. Start-up: the learner steps its own
copy of the task once before any worker starts, so Numba compiles the kernels once and the
workers of this machine load them from its cache (``__pycache__`` beside the sources);
workers on other machines compile once per machine.

Cluster. ``ray start --head`` on one machine, ``ray start --address=HEAD:6379`` on the
others, then ``tumble train imitate walk --ray HEAD:6379 --workers K`` on the head: the
checkpoints and logs are written by the learner, in ``--out`` on the head machine.
"""
import os
import time
from pathlib import Path

import numpy as np

try:
    import ray
    import torch
    from tensordict import TensorDict
except ImportError as exc:          # the optional extras are missing
    raise ImportError('tumble.rl.distributed needs Ray and PyTorch: pip install '
                      '"tumble[rl,ray]"') from exc

from ..errors import ModelError
from .train import (RolloutStats, Trainer, TrainConfig, _TorchVecEnv, _make_env,
                    collect_rollout, make_algorithm, make_style, update_normalizers,
                    warm_up_observations)

__all__ = ["RayTrainer", "RolloutWorker", "init_ray"]

# the directory holding the tumble package: workers import it from where the learner does
_SOURCE_ROOT = str(Path(__file__).resolve().parents[2])


def init_ray(address=None, num_cpus=None):
    """Connect to the Ray cluster at ``address`` ('auto' or 'HOST:PORT'), or start a local
    one with ``num_cpus``; nothing if Ray is already initialised. The workers import tumble
    from the same place as this process. A local cluster's workers run at the learner's
    priority: Ray starts them at niceness 15, which left them a few percent of a core
    beside any other busy process (a worker took 13 s to import PyTorch and tumble
    instead of 3)."""
    if ray.is_initialized():
        return
    env = {"env_vars": {"PYTHONPATH": os.pathsep.join(
        p for p in (_SOURCE_ROOT, os.environ.get("PYTHONPATH", "")) if p)}}
    kwargs = dict(runtime_env=env, include_dashboard=False, log_to_driver=False,
                  configure_logging=False)
    if address is not None:
        ray.init(address=address, **kwargs)
    else:
        ray.init(num_cpus=num_cpus, _system_config={"worker_niceness": 0}, **kwargs)


def _tensor(a):
    """A tensor of an array from Ray's object store (read-only there: copied if so)."""
    return torch.from_numpy(np.require(a, requirements="W"))


class RolloutWorker:
    """A Ray actor's body: ``config.num_envs`` worlds of the run's task and a copy of the
    learner's networks (see the module docs). ``threads``: Numba's and PyTorch's threads
    in this worker (its CPUs)."""

    def __init__(self, config, seed, threads=1):
        t0 = time.perf_counter()
        import numba
        numba.set_num_threads(max(1, min(int(threads), numba.config.NUMBA_NUM_THREADS)))
        torch.set_num_threads(max(1, int(threads)))
        c = TrainConfig.from_dict(config)
        self.steps = c.steps_per_env
        self.env = _make_env(c, c.num_envs, seed=seed, episode_seconds=c.episode_seconds)
        self.vec = _TorchVecEnv(self.env, self.env.max_episode_steps)
        self.style = make_style(c, self.env)
        self.alg = make_algorithm(c, c.num_envs, self.env.observation_size,
                                  self.env.action_size)
        self.alg.train_mode()
        self.vec.get_observations()             # resets the worlds: the kernels load here
        self.startup_seconds = time.perf_counter() - t0

    def info(self):
        """(process id, seconds the worker took to start, worlds)."""
        return os.getpid(), self.startup_seconds, self.env.num_envs

    def _load(self, weights, rng_state):
        self.alg.actor.load_state_dict(weights["actor"])
        self.alg.critic.load_state_dict(weights["critic"])
        if self.style is not None:
            self.style.disc.load_state_dict(weights["disc"])
        torch.set_rng_state(rng_state)

    def warm_up(self, weights, rng_state):
        """The initial policy's observations for the normalisers, and the generator."""
        self._load(weights, rng_state)
        data = warm_up_observations(self.alg, self.vec, self.steps)
        return data.numpy(), torch.get_rng_state()

    def rollout(self, weights, rng_state):
        """One rollout with the given networks: (storage arrays, last observations,
        RolloutStats, AMP transitions or None, the generator's state after it)."""
        self._load(weights, rng_state)
        st = self.alg.storage
        st.clear()
        obs, stats = collect_rollout(self.alg, self.vec, self.style, self.steps,
                                     self.vec.get_observations())
        arrays = {"obs": st.observations["policy"].numpy().copy(),
                  "actions": st.actions.numpy().copy(), "rewards": st.rewards.numpy().copy(),
                  "dones": st.dones.numpy().copy(), "values": st.values.numpy().copy(),
                  "log_prob": st.actions_log_prob.numpy().copy(),
                  "dist": [p.numpy().copy() for p in st.distribution_params]}
        amp = None
        if self.style is not None:
            amp = torch.cat(self.style._rollout).numpy()
            self.style._rollout = []
        return arrays, obs["policy"].numpy().copy(), stats, amp, torch.get_rng_state()


class RayTrainer(Trainer):
    """A :class:`~tumble.rl.train.Trainer` whose samples come from ``workers`` Ray actors
    of ``config.num_envs`` worlds each (so an iteration holds workers x num_envs x
    steps_per_env samples).

    address : a Ray cluster ('auto', 'HOST:PORT'); None starts a local one with ``workers``
        x ``worker_cpus`` CPUs (unless Ray is already initialised).
    worker_cpus : CPUs (Numba and PyTorch threads) of each worker.
    Everything else as :class:`Trainer`; ``worker_restarts`` counts replaced workers.
    """

    def __init__(self, out_dir, config=None, *, workers=2, address=None, worker_cpus=1,
                 resume=False, progress=True, log=print, env_overrides=None):
        if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1:
            raise ModelError(f"RayTrainer: workers must be a positive integer, got {workers!r}")
        if isinstance(worker_cpus, bool) or not isinstance(worker_cpus, (int, np.integer)) \
                or worker_cpus < 1:
            raise ModelError(f"RayTrainer: worker_cpus must be a positive integer, got "
                             f"{worker_cpus!r}")
        self.num_workers = int(workers)
        self.worker_cpus = int(worker_cpus)
        self.address = address
        self.worker_restarts = 0
        self._workers = []
        self._generation = [0] * self.num_workers
        super().__init__(out_dir, config, resume=resume, progress=progress, log=log,
                         env_overrides=env_overrides)

    # -- the sampler: workers ------------------------------------------------------------
    def _make_sampler(self):
        c = self.config
        init_ray(self.address, self.num_workers * self.worker_cpus)
        # the learner's own copy of the task: the policy's spec, the clips' transitions for
        # the discriminator, and one step that compiles (or loads) the kernels before any
        # worker starts, so that the workers of this machine find them in the cache
        self.env = _make_env(c, c.num_envs, seed=c.seed, episode_seconds=c.episode_seconds)
        self.env.reset()
        self.env.step(np.zeros((self.env.num_envs, self.env.action_size)))
        self.vec = None
        self.style = make_style(c, self.env)
        self.alg = make_algorithm(c, self.num_workers * c.num_envs, self.env.observation_size,
                                  self.env.action_size)
        self._actor_class = ray.remote(num_cpus=self.worker_cpus, max_restarts=0)(RolloutWorker)
        self._workers = [self._start_worker(k) for k in range(self.num_workers)]
        self.worker_info = ray.get([w.info.remote() for w in self._workers])

    def _worker_seed(self, k):
        """Worker k's worlds: the run's seed for worker 0 at the start (as a single-process
        run), then distinct seeds for other workers, resumed runs and replacements."""
        return int(self.config.seed + k + 7919 * self._generation[k]
                   + 104729 * getattr(self, "iteration", 0))

    def _start_worker(self, k):
        return self._actor_class.remote(self.config.to_dict(), self._worker_seed(k),
                                        self.worker_cpus)

    def _replace_worker(self, k, exc):
        self.worker_restarts += 1
        self._generation[k] += 1
        if self.log:
            self.log(f"worker {k} failed ({type(exc).__name__}); starting a new one "
                     f"({self.worker_restarts} replaced so far)")
        try:
            ray.kill(self._workers[k])
        except Exception:              # it is gone already
            pass
        self._workers[k] = self._start_worker(k)

    def _weights(self):
        w = {"actor": {k: v.detach().clone() for k, v in self.alg.actor.state_dict().items()},
             "critic": {k: v.detach().clone() for k, v in self.alg.critic.state_dict().items()}}
        if self.style is not None:
            w["disc"] = self.style.disc.state_dict()
        return ray.put(w)

    def _rng_states(self):
        """Generator states: the learner's for worker 0, seeded ones for the others."""
        states = [torch.get_rng_state()]
        for k in range(1, self.num_workers):
            g = torch.Generator()
            g.manual_seed(int(self.config.seed) * 1_000_003 + 7919 * k
                          + 104729 * getattr(self, "iteration", 0))
            states.append(g.get_state())
        return states

    def _call_all(self, method, weights):
        """``method(weights, rng_state)`` on every worker; a worker that dies is replaced and
        asked again. Returns the results in worker order and sets the learner's generator
        to where worker 0 left it."""
        states = self._rng_states()
        refs = [getattr(w, method).remote(weights, states[k]) for k, w in enumerate(self._workers)]
        results = [None] * self.num_workers
        for k in range(self.num_workers):
            for attempt in range(4):
                try:
                    results[k] = ray.get(refs[k])
                    break
                except (ray.exceptions.RayActorError, ray.exceptions.WorkerCrashedError) as exc:
                    if attempt == 3:
                        raise ModelError(f"RayTrainer: worker {k} failed 4 times in a row; "
                                         f"last: {exc}") from exc
                    self._replace_worker(k, exc)
                    refs[k] = getattr(self._workers[k], method).remote(weights, states[k])
        torch.set_rng_state(results[0][-1])
        return results

    def _warm_up_normalizers(self):
        results = self._call_all("warm_up", self._weights())
        data = np.concatenate([r[0] for r in results])
        update_normalizers(self.alg, _tensor(data))

    def _collect(self):
        results = self._call_all("rollout", self._weights())
        st = self.alg.storage
        n = self.config.num_envs
        for k, (arrays, _, _, _, _) in enumerate(results):
            sl = slice(k * n, (k + 1) * n)
            st.observations["policy"][:, sl] = _tensor(arrays["obs"])
            st.actions[:, sl] = _tensor(arrays["actions"])
            st.rewards[:, sl] = _tensor(arrays["rewards"])
            st.dones[:, sl] = _tensor(arrays["dones"])
            st.values[:, sl] = _tensor(arrays["values"])
            st.actions_log_prob[:, sl] = _tensor(arrays["log_prob"])
            if st.distribution_params is None:
                st.distribution_params = tuple(
                    torch.zeros(st.num_transitions_per_env, st.num_envs, *p.shape[2:])
                    for p in arrays["dist"])
            for i, p in enumerate(arrays["dist"]):
                st.distribution_params[i][:, sl] = _tensor(p)
        st.step = st.num_transitions_per_env
        last = np.concatenate([r[1] for r in results])
        with torch.inference_mode():
            self.alg.compute_returns(TensorDict({"policy": _tensor(last)},
                                                batch_size=[last.shape[0]]))
        if self.style is not None:
            self.style._rollout = [_tensor(np.concatenate([r[3] for r in results]))]
        return RolloutStats.merged([r[2] for r in results])

    def close(self):
        """Stop the workers (the Ray cluster stays up)."""
        for w in self._workers:
            try:
                ray.kill(w)
            except Exception:          # already gone
                pass
        self._workers = []
