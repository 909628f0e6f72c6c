"""Policy input features computed from the observation (``--features``), for SB3 policies.

``flat`` (default): the policy's MLPs read the observation as it is.

``contact``: the MLPs read the observation followed by three numbers per neighbour slot, all
computed from that slot's own features (:mod:`vcs_env.observations`) and the robot's, so they
add no information, only resolution where it matters: the observation's fixed scales put a
0.3 m gap at 0.03 and a closing speed of 1 m/s at 0.17, and leave the time to contact to be
worked out from five of its numbers, while a collision is decided at exactly that scale. Per
slot, with relative position ``p`` and velocity ``u`` [m, m/s], the summed radii ``R`` [m], the
gap ``g`` [m], and the object's own velocity ``w = u + (own speed, 0)`` [m/s]:

====== ==================================================================================
+0     ``exp(-t_c / T_REF)``: ``t_c`` [s] is when ``|p + u t| = R`` first holds at the current
       velocities (0 when touching, never: the feature is 0)
+1     ``exp(-max(g, 0) / G_REF)``: nearness of the surfaces
+2     ``exp(-t_r / T_REF)``, ``t_r = max(g, 0) / (v_max + |w|)`` [s]: the soonest the two
       could meet if the robot drove straight at the object at its top speed (the reach the
       VCS expert's ``crowd_reach`` guards, vcs-method §2.7)
====== ==================================================================================

Padding slots read 0. Being computed from the observation, they see what it sees: positions
and gaps beyond its 10 m scale are clipped there.

``slots``: a learned encoder (:class:`SlotEncoder`) shared by every neighbour slot reads that
slot's features, its ``contact`` block and the robot's own block; the MLPs read the robot's own
block, the rest of the observation after the slots (lidar) and the maximum and the mean of the codes
of the real slots. The nearest points on walls, when the observation has them, are slots too
(:func:`wall_slots`: still objects of radius 0), read by the same encoder (runs before 2026-11-28
read them as flat numbers beside the lidar; their checkpoints keep doing so). When the wall points have
their segment fields (``Scenario.wall_segments``), a wall point's time to contact in its ``contact``
block is its wall segment's (:func:`segment_contact_time`), not the point's as a still disc. It does not
depend on the order of the slots, and one set of weights judges every neighbour. Actor and critic each
train their own encoder.

``slots-fine``: ``slots`` whose encoder also reads, per slot, the same contact at millimetre resolution: the
``contact`` block's scales put a 5 mm gap and a 20 mm one at 0.99 and 0.96 of ``exp(-g / G_REF)``, while the
v2 network's last contacts on the maps are creeping ones, a robot edging into a wall or a robot by millimetres
a step (``docs/experiments.md``, "What the v2 network's last contacts are"). Two numbers follow the robot's own
block in each slot's input, 0 in padding slots:

====== ==================================================================================
+0     ``exp(-max(g, 0) / FINE_G_REF)``, ``FINE_G_REF`` = 0.02 m
+1     ``exp(-t_c / FINE_T_REF)``, ``FINE_T_REF`` = 0.25 s (``t_c`` as in ``contact``)
====== ==================================================================================

:func:`widen_fine` turns a ``slots`` network into a ``slots-fine`` one that acts the same (the new inputs' weights
start at zero), for ``vcs-env distil --init CHECKPOINT --widen-fine``.

``--features`` is part of the architecture a checkpoint stores (SB3 pickles the class into
``model.zip``, and ``--init`` refuses a checkpoint with other tensors). The oracles are in
``tests/test_features.py``. RLlib policies read the flat observation only.
"""

from __future__ import annotations

from typing import Any

import torch
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor

from vcs_env.observations import EGO_DIM, SENSE_REF, Layout
from vcs_env.scenario import R_REF, V_REF

from .config import FEATURES

CONTACT_DIM = 3
"""Features per neighbour slot added by ``contact``."""
T_REF = 2.0
"""Time scale of the contact and reach features [s]."""
G_REF = 0.5
"""Length scale of the nearness feature [m]."""
V1_NEIGHBOR_DIM = 8
"""Floats per neighbour slot of observation v1: what checkpoints without ``neighbor_dim`` in their
``features_extractor_kwargs`` read."""
FINE_DIM = 2
"""Inputs per slot added by ``slots-fine`` (module docstring)."""
FINE_G_REF = 0.02
"""Length scale of ``slots-fine``'s nearness input [m]."""
FINE_T_REF = 0.25
"""Time scale of ``slots-fine``'s contact-time input [s]."""
SLOT_WIDTH = 64
"""Width of the ``slots`` encoder's hidden layer (its code has ``SLOT_WIDTH // 2`` numbers). Stored in
every checkpoint's ``features_extractor_kwargs``; checkpoints without it were trained at 128."""


def check_features(name: str) -> str:
    """Return ``name`` if it is one of :data:`FEATURES`; raise ``ValueError`` naming them otherwise."""
    if name not in FEATURES:
        raise ValueError(f"features must be one of {list(FEATURES)}, got {name!r}")
    return name


def contact_features(obs: torch.Tensor, n_neighbors: int, neighbor_dim: int = V1_NEIGHBOR_DIM) -> torch.Tensor:
    """The ``contact`` block ``(N, n_neighbors * CONTACT_DIM)`` of observations ``(N, D)`` whose neighbour
    slots (after the ``EGO_DIM`` ego block) have ``neighbor_dim`` floats (8: observation v1, 9: v2)."""
    slots = obs[:, EGO_DIM : EGO_DIM + n_neighbors * neighbor_dim].reshape(-1, n_neighbors, neighbor_dim)
    return slot_contacts(obs, slots).reshape(obs.shape[0], n_neighbors * CONTACT_DIM)


def wall_block(obs: torch.Tensor, walls: int, wall_dim: int = 3) -> torch.Tensor:
    """The ``wall_points`` block of observations ``(N, D)``, their last ``walls * wall_dim`` numbers, as
    ``(N, walls, wall_dim)``: ``valid, x, y`` per point, then, with ``wall_dim`` 7, its segment's ``tx, ty, back,
    ahead`` (:mod:`vcs_env.observations`)."""
    return obs[:, obs.shape[1] - wall_dim * walls :].reshape(obs.shape[0], walls, wall_dim)


def wall_slots(obs: torch.Tensor, block: torch.Tensor, neighbor_dim: int) -> torch.Tensor:
    """The wall points ``block`` ``(N, walls, wall_dim)`` of observations ``(N, D)`` (:func:`wall_block`) as neighbour
    slots ``(N, walls, neighbor_dim)``: each nearest point on a wall a still object of radius 0 (mask = valid, its
    position, velocity relative to the robot ``-(own speed, 0)``, gap = distance - own radius, not a robot, not
    parked)."""
    n, walls = block.shape[:2]
    valid, p = block[..., 0], block[..., 1:3]
    out = torch.zeros(n, walls, neighbor_dim, dtype=obs.dtype, device=obs.device)
    out[..., 0] = valid
    out[..., 1:3] = p
    own_speed = obs[:, 0:1] * obs[:, 4:5] * V_REF  # [m/s]
    out[..., 3] = -own_speed / (2.0 * V_REF) * valid
    gap = (torch.sqrt((p * p).sum(-1)) * SENSE_REF - obs[:, 7:8] * R_REF) / SENSE_REF
    out[..., 6] = gap * valid
    return out


def slot_contacts(obs: torch.Tensor, slots: torch.Tensor, segments: torch.Tensor | None = None) -> torch.Tensor:
    """The contact features ``(N, S, CONTACT_DIM)`` of neighbour slots ``(N, S, d)`` of observations ``(N, D)``
    (module docstring; 0 in padding slots). With ``segments`` ``(N, W, 4)`` (the segment fields of the wall
    points, :mod:`vcs_env.observations`), the last W slots are points on walls (:func:`wall_slots`) and their time to
    contact is their wall segment's (:func:`segment_contact_time`), not the point's."""
    v_max = obs[:, 4:5] * V_REF  # [m/s]
    own_speed = obs[:, 0:1] * v_max  # [m/s], forward in the robot frame
    own_radius = obs[:, 7:8] * R_REF  # [m]
    mask = slots[..., 0]
    p = slots[..., 1:3] * SENSE_REF
    u = slots[..., 3:5] * (2.0 * V_REF)
    radii = slots[..., 5] * R_REF + own_radius
    gap = slots[..., 6] * SENSE_REF
    k = p.shape[1] - (0 if segments is None else segments.shape[1])  # the slots timed as discs
    # First root of |p + u t|^2 = R^2 for t >= 0: a t^2 + b t + c = 0.
    pk, uk = p[:, :k], u[:, :k]
    a = (uk * uk).sum(-1)
    b = 2.0 * (pk * uk).sum(-1)
    c = (pk * pk).sum(-1) - radii[:, :k] ** 2
    disc = b * b - 4.0 * a * c
    closing = (b < 0) & (disc >= 0) & (a > 1e-12)
    root = (-b - torch.sqrt(torch.clamp(disc, min=0.0))) / (2.0 * torch.clamp(a, min=1e-12))
    t_c = torch.where(c <= 0, torch.zeros_like(c), torch.where(closing, root.clamp(min=0.0), torch.full_like(c, 1e9)))
    if segments is not None:  # the wall points: their segments' times
        wall = segment_contact_time(own_speed, p[:, k:], segments, own_radius, gap[:, k:])
        t_c = torch.cat((t_c, wall), dim=1)
    w = u.clone()
    w[..., 0] = w[..., 0] + own_speed
    reach_speed = v_max + torch.sqrt((w * w).sum(-1))
    t_r = gap.clamp(min=0.0) / reach_speed.clamp(min=1e-6)
    block = torch.stack(
        (torch.exp(-t_c / T_REF), torch.exp(-gap.clamp(min=0.0) / G_REF), torch.exp(-t_r / T_REF)), dim=-1
    )
    return block * mask[..., None]


def segment_contact_time(
    own_speed: torch.Tensor, p: torch.Tensor, segments: torch.Tensor, radius: torch.Tensor, gap: torch.Tensor
) -> torch.Tensor:
    """Time to contact [s] ``(N, W)`` of a robot driving ahead at ``own_speed`` ``(N, 1)`` [m/s] (radius ``radius``
    ``(N, 1)`` [m]) with the wall segments through its nearest points ``p`` ``(N, W, 2)`` [m, robot frame], each
    given by ``segments`` ``(N, W, 4)``: its unit direction ``(tx, ty)`` and how far it runs from ``p`` backward and
    forward, / ``SENSE_REF`` (the observation's fields); ``gap`` ``(N, W)`` [m] the distance minus the radius. The
    first time the robot's disc meets the segment: its side (the line, where the meeting point lies between the
    ends) or an end (a point): 0 when touching, 1e9 (never) when it passes. A robot driving at a slant at a wall
    closes on it at ``speed * cos(angle)``, where the nearest point seen as a still disc of radius 0 (the
    ``contact`` feature's model) is passed by: 4 of the 6 at-fault wall contacts of the v2 network on ``walls-v0``'s
    seeds 8000-8199 read "never" that way 0.4-1.2 s before (``docs/experiments.md``); the segment's ends keep a
    door post from reading as a wall across the door."""
    t = segments[..., :2]
    back, ahead = segments[..., 2] * SENSE_REF, segments[..., 3] * SENSE_REF
    v = own_speed.expand_as(gap)
    never = torch.full_like(gap, 1e9)
    # The side: the line's normal turned toward the robot, its distance d0 from the robot's centre.
    normal = torch.stack((-t[..., 1], t[..., 0]), dim=-1)
    d0 = -(p * normal).sum(-1)
    normal = torch.where((d0 < 0)[..., None], -normal, normal)
    d0 = d0.abs()
    approach = -v * normal[..., 0]  # [m/s] toward the line
    t_line = ((d0 - radius) / approach.clamp(min=1e-9)).clamp(min=0.0)
    along = v * t_line * t[..., 0] - (p * t).sum(-1)  # where the centre meets the line's band, along t from p [m]
    side = torch.where((approach > 1e-9) & (along >= -back) & (along <= ahead), t_line, never)

    def end_time(q):  # first time |q - (v t, 0)| = radius, q (N, W, 2)
        c = (q * q).sum(-1) - radius**2
        b = -2.0 * v * q[..., 0]
        a = (v * v).clamp(min=1e-12)
        disc = b * b - 4.0 * a * c
        root = ((-b - torch.sqrt(disc.clamp(min=0.0))) / (2.0 * a)).clamp(min=0.0)
        return torch.where(c <= 0, torch.zeros_like(c), torch.where((b < 0) & (disc >= 0) & (v > 1e-6), root, never))

    ends = torch.minimum(end_time(p - back[..., None] * t), end_time(p + ahead[..., None] * t))
    return torch.where(gap <= 0, torch.zeros_like(gap), torch.minimum(side, ends))


class ContactFeatures(BaseFeaturesExtractor):
    """The observation followed by :func:`contact_features` (module docstring)."""

    def __init__(self, observation_space, n_neighbors: int, neighbor_dim: int = V1_NEIGHBOR_DIM):
        super().__init__(observation_space, observation_space.shape[0] + n_neighbors * CONTACT_DIM)
        self.n_neighbors, self.neighbor_dim = n_neighbors, neighbor_dim

    def forward(self, observations: torch.Tensor) -> torch.Tensor:
        contact = contact_features(observations, self.n_neighbors, self.neighbor_dim)
        return torch.cat((observations, contact), dim=-1)


class SlotEncoder(BaseFeaturesExtractor):
    """``slots``: one small MLP shared by every neighbour slot, pooled over the real ones.

    Each slot reads its own features, its :func:`contact_features` and the robot's own block
    (``EGO_DIM``), ``(N, k, neighbor_dim + CONTACT_DIM + EGO_DIM)``, and with ``fine`` the ``FINE_DIM`` inputs of
    ``slots-fine`` (module docstring); the encoder (two layers of
    ``width``, ReLU) maps it to ``width // 2`` numbers; the masked maximum and mean over the real
    slots (0 with none) follow the robot's own block and whatever the observation has after the
    slots (wall points, lidar). The same object reads the same wherever it sorts, and the weights
    that judge one neighbour judge them all.
    """

    def __init__(
        self,
        observation_space,
        n_neighbors: int,
        width: int = 128,
        neighbor_dim: int = V1_NEIGHBOR_DIM,
        wall_slots: int = 0,
        fine: bool = False,
        wall_dim: int = 3,
    ):
        self.n_neighbors, self.width, self.neighbor_dim, self.wall_slots = n_neighbors, width, neighbor_dim, wall_slots
        self.fine, self.wall_dim = fine, wall_dim
        rest = observation_space.shape[0] - n_neighbors * neighbor_dim - wall_dim * wall_slots
        super().__init__(observation_space, rest + 2 * (width // 2))  # + the maximum and the mean
        self.encoder = torch.nn.Sequential(
            torch.nn.Linear(neighbor_dim + CONTACT_DIM + EGO_DIM + FINE_DIM * fine, width),
            torch.nn.ReLU(),
            torch.nn.Linear(width, width // 2),
            torch.nn.ReLU(),
        )

    def forward(self, observations: torch.Tensor) -> torch.Tensor:
        k, n, d, walls = self.n_neighbors, observations.shape[0], self.neighbor_dim, self.wall_slots
        end = EGO_DIM + k * d
        ego = observations[:, :EGO_DIM]
        slots = observations[:, EGO_DIM:end].reshape(n, k, d)
        segments = None
        if walls:  # the nearest points on walls are slots too, read by the same encoder
            block = wall_block(observations, walls, self.wall_dim)
            slots = torch.cat((slots, wall_slots(observations, block, d)), dim=1)
            if self.wall_dim >= 7:  # with the segment fields, their time to contact is their wall segment's
                segments = block[..., 3:7]
        contact = slot_contacts(observations, slots, segments)
        mask = slots[..., :1]  # (N, k, 1)
        parts = [slots, contact, ego[:, None, :].expand(n, slots.shape[1], EGO_DIM)]
        if self.fine:  # slots-fine: the gap and the time to contact at millimetre resolution (module docstring)
            gap = (slots[..., 6] * SENSE_REF).clamp(min=0.0)  # [m]
            near = torch.exp(-gap / FINE_G_REF)
            soon = contact[..., 0] ** (T_REF / FINE_T_REF)  # exp(-t_c / T_REF) ** (T_REF / FINE_T_REF)
            parts.append(torch.stack((near, soon), dim=-1) * mask)
        x = torch.cat(parts, dim=-1)
        h = self.encoder(x) * mask  # ReLU outputs >= 0, so zeroed padding never wins the maximum
        pooled_max = h.max(dim=1).values
        pooled_mean = h.sum(dim=1) / mask.sum(dim=1).clamp(min=1.0)
        rest = observations[:, end : observations.shape[1] - self.wall_dim * walls]
        return torch.cat((ego, rest, pooled_max, pooled_mean), dim=-1)


def extractor_kwargs(features: str, layout: Layout) -> dict[str, Any]:
    """``policy_kwargs`` entries of SB3's ``MlpPolicy`` for ``features`` (none for ``flat``) on observations of
    ``layout`` (:func:`vcs_env.observations.observation_layout`)."""
    if check_features(features) == "flat":
        return {}
    cls = ContactFeatures if features == "contact" else SlotEncoder
    nb = layout.block("neighbors")
    kwargs = {
        "features_extractor_class": cls,
        "features_extractor_kwargs": {"n_neighbors": nb.items, "neighbor_dim": nb.item_dim},
    }
    if cls is SlotEncoder:  # the encoder has weights: actor and critic each train their own
        kwargs["features_extractor_kwargs"]["width"] = SLOT_WIDTH
        if features == "slots-fine":
            kwargs["features_extractor_kwargs"]["fine"] = True
        kwargs["share_features_extractor"] = False
        if "wall_points" in layout:  # the last block (vcs_env.observations): the encoder reads it as slots
            assert layout.blocks[-1].name == "wall_points"
            kwargs["features_extractor_kwargs"]["wall_slots"] = layout.block("wall_points").items
            if layout.block("wall_points").item_dim != 3:  # with the segment fields (Scenario.wall_segments)
                kwargs["features_extractor_kwargs"]["wall_dim"] = layout.block("wall_points").item_dim
    return kwargs


def widen_fine(model) -> None:
    """Turn the ``slots`` encoders of an SB3 ``model`` (actor's and critic's) into ``slots-fine`` ones in place: the
    first layer gains ``FINE_DIM`` input columns of zero weights, so the model acts and values as before to the last
    bit; ``model.policy_kwargs`` records the change (saved checkpoints load as ``slots-fine``) and the optimizer is
    rebuilt over the new parameters. ``ValueError`` for a model without ``slots`` encoders or already fine."""
    policy = getattr(model, "policy", None)
    extractors = [getattr(policy, name, None) for name in ("pi_features_extractor", "vf_features_extractor")]
    if not all(isinstance(e, SlotEncoder) for e in extractors):
        raise ValueError("widen_fine takes an SB3 model with --features slots (a SlotEncoder for actor and critic)")
    if any(e.fine for e in extractors):
        raise ValueError("widen_fine: the model's encoders already read the slots-fine inputs")
    kwargs = {**policy.features_extractor_kwargs, "fine": True}
    widened = {}  # one new encoder per old one (actor and critic may share theirs)
    for name, old in zip(("pi_features_extractor", "vf_features_extractor"), extractors):
        if id(old) not in widened:
            new = SlotEncoder(policy.observation_space, **kwargs).to(policy.device)
            state = old.state_dict()
            w = state["encoder.0.weight"]
            state["encoder.0.weight"] = torch.cat((w, w.new_zeros(w.shape[0], FINE_DIM)), dim=1)
            new.load_state_dict(state)
            widened[id(old)] = new
        setattr(policy, name, widened[id(old)])
    policy.features_extractor = policy.pi_features_extractor
    policy.features_extractor_kwargs = kwargs
    model.policy_kwargs["features_extractor_kwargs"] = kwargs
    policy.optimizer = policy.optimizer_class(policy.parameters(), lr=model.lr_schedule(1), **policy.optimizer_kwargs)
