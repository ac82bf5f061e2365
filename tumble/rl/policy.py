"""Trained policies as files: weights and what they were trained on, run without PyTorch.

A policy file (``.npz``) holds the actor network of a trained policy (an MLP: the weights
and biases of each layer, its activation, the observation normaliser's mean and standard
deviation) and its ``spec``: the task, the character's body and joint names and mass, the
observation and action sizes, the control and physics rates, the action mode and the
clip. :class:`Policy` loads it and maps observations to actions in NumPy, so ``tumble
play`` needs neither PyTorch nor the learning library; :meth:`Policy.check` refuses an
environment the policy was not trained for, naming what differs.
"""
import json
import os
from pathlib import Path

import numpy as np

from ..errors import ModelError

__all__ = ["Policy", "POLICY_FORMAT"]

POLICY_FORMAT = 1
_ACTIVATIONS = {
    "elu": lambda x: np.where(x > 0.0, x, np.expm1(np.minimum(x, 0.0))),
    "relu": lambda x: np.maximum(x, 0.0),
    "tanh": np.tanh,
}
# Spec fields that must agree between a policy and the environment it is run in.
_MUST_MATCH = ("task", "body_names", "joint_names", "observation_size", "action_size",
               "control_hz", "residual", "action_scale")


class Policy:
    """A deterministic policy: ``act(obs (N, D)) -> actions (N, A)`` in [-1, 1].

    weights, biases : lists of (out, in) and (out,) arrays, one per layer;
    activation : 'elu', 'relu' or 'tanh' between layers (none after the last);
    obs_mean, obs_std, obs_eps : the normaliser, ``(obs - mean) / (std + eps)``;
    spec : dict (see the module docs); info : dict of training facts (samples, wall time...).
    """

    def __init__(self, weights, biases, activation, obs_mean, obs_std, obs_eps, spec, info=None):
        if activation not in _ACTIVATIONS:
            raise ModelError(f"policy: unknown activation {activation!r}")
        self.weights = [np.asarray(w, np.float64) for w in weights]
        self.biases = [np.asarray(b, np.float64) for b in biases]
        self.activation = activation
        self.obs_mean = np.asarray(obs_mean, np.float64)
        self.obs_std = np.asarray(obs_std, np.float64)
        self.obs_eps = float(obs_eps)
        self.spec = dict(spec)
        self.info = dict(info or {})
        D = self.weights[0].shape[1]
        if self.obs_mean.shape != (D,) or self.obs_std.shape != (D,):
            raise ModelError(f"policy: normaliser of size {self.obs_mean.shape} for a network "
                             f"of input {D}")
        if spec.get("observation_size", D) != D:
            raise ModelError(f"policy: spec says {spec.get('observation_size')} observations, "
                             f"the network takes {D}")

    @property
    def observation_size(self):
        return self.weights[0].shape[1]

    @property
    def action_size(self):
        return self.weights[-1].shape[0]

    def act(self, obs):
        """Actions (N, A) float32 for observations (N, D) (or (D,) -> (A,)), clipped to [-1, 1]."""
        x = np.asarray(obs, np.float64)
        single = x.ndim == 1
        x = np.atleast_2d(x)
        if x.shape[1] != self.observation_size:
            raise ModelError(f"policy: observations of size {x.shape[1]}, the policy takes "
                             f"{self.observation_size}")
        x = (x - self.obs_mean) / (self.obs_std + self.obs_eps)
        f = _ACTIVATIONS[self.activation]
        for k, (w, b) in enumerate(zip(self.weights, self.biases)):
            x = x @ w.T + b
            if k < len(self.weights) - 1:
                x = f(x)
        a = np.clip(x, -1.0, 1.0).astype(np.float32)
        return a[0] if single else a

    def check(self, env_spec):
        """Raise ModelError if ``env_spec`` (``ImitationEnv.spec()``) differs from the policy's
        in anything the policy depends on (character, sizes, rates, action mode)."""
        diffs = []
        for k in _MUST_MATCH:
            mine, theirs = self.spec.get(k), env_spec.get(k)
            if isinstance(mine, list) or isinstance(theirs, list):
                same = mine is not None and theirs is not None and len(mine) == len(theirs) and \
                    all(a == b if isinstance(a, str) else np.isclose(a, b)
                        for a, b in zip(mine, theirs))
            else:
                same = mine == theirs
            if not same:
                diffs.append(f"{k}: policy {_short(mine)}, environment {_short(theirs)}")
        mass_p, mass_e = self.spec.get("total_mass"), env_spec.get("total_mass")
        if mass_p is not None and mass_e is not None and not np.isclose(mass_p, mass_e, rtol=1e-6):
            diffs.append(f"total_mass: policy {mass_p:.6g} kg, environment {mass_e:.6g} kg")
        if diffs:
            raise ModelError("policy: trained for another setting; " + "; ".join(diffs))

    def save(self, path):
        """Write the policy to ``path`` (.npz, added if missing), atomically."""
        arrays = {f"w{k}": w for k, w in enumerate(self.weights)}
        arrays.update({f"b{k}": b for k, b in enumerate(self.biases)})
        meta = {"format": POLICY_FORMAT, "activation": self.activation, "obs_eps": self.obs_eps,
                "layers": len(self.weights), "spec": self.spec, "info": self.info}
        # written beside and renamed: a reader (tumble play during training) or a kill
        # mid-write never sees half a file
        path = Path(path)
        if path.suffix != ".npz":            # as np.savez names it
            path = path.with_name(path.name + ".npz")
        tmp = path.with_name(path.name + ".tmp")
        with open(tmp, "wb") as f:
            np.savez_compressed(f, obs_mean=self.obs_mean, obs_std=self.obs_std,
                                meta=np.array(json.dumps(meta)), **arrays)
        os.replace(tmp, path)

    @classmethod
    def load(cls, path):
        """Read a policy file (ModelError if it is not one, or of a newer format)."""
        p = Path(path)
        try:
            with np.load(p, allow_pickle=False) as z:
                meta = json.loads(str(z["meta"]))
                n = int(meta["layers"])
                weights = [z[f"w{k}"] for k in range(n)]
                biases = [z[f"b{k}"] for k in range(n)]
                mean, std = z["obs_mean"], z["obs_std"]
        except FileNotFoundError:
            raise ModelError(f"policy: no file {str(p)!r}") from None
        except (OSError, KeyError, ValueError, TypeError) as exc:
            raise ModelError(f"policy: {str(p)!r} is not a tumble policy file ({exc})") from None
        if meta.get("format", 0) > POLICY_FORMAT:
            raise ModelError(f"policy: {str(p)!r} has format {meta['format']}; this tumble "
                             f"reads up to {POLICY_FORMAT}")
        return cls(weights, biases, meta["activation"], mean, std, meta["obs_eps"],
                   meta["spec"], meta.get("info"))

    def __repr__(self):
        sizes = [self.observation_size] + [w.shape[0] for w in self.weights]
        return (f"<tumble.rl.Policy: {self.spec.get('task')} {self.spec.get('clip')}, "
                f"MLP {sizes} ({self.activation})>")


def _short(v):
    if isinstance(v, list) and len(v) > 6:
        return f"[{', '.join(map(str, v[:3]))}, ... ({len(v)} items)]"
    return repr(v)
