"""Creative Cooking (paper Sec. VII and Appendix): domain, Gymnasium environment, LTLf knowledge
base, and the expert that writes demonstrations. A synthetic environment built from the paper's
appendix; see docs/cooking.md.

Importing this package registers `tleaf/CreativeCooking-v0` (a 50-step TimeLimit) with Gymnasium:

    import gymnasium as gym
    import tleaf_cli.tasks.cooking
    env = gym.make("tleaf/CreativeCooking-v0", render_mode="ansi")
"""

from __future__ import annotations

import gymnasium

from tleaf_cli.tasks.cooking.domain import DEFAULT_DOMAIN, Domain, load_domain
from tleaf_cli.tasks.cooking.rules import ActionCodec, EpisodeRules, decode_action, encode_action

ENV_ID = "tleaf/CreativeCooking-v0"
MAX_EPISODE_STEPS = 50

if ENV_ID not in gymnasium.registry:
    gymnasium.register(
        id=ENV_ID,
        entry_point="tleaf_cli.tasks.cooking.env:CreativeCookingEnv",
        max_episode_steps=MAX_EPISODE_STEPS,
    )

__all__ = [
    "DEFAULT_DOMAIN",
    "ENV_ID",
    "MAX_EPISODE_STEPS",
    "ActionCodec",
    "Domain",
    "EpisodeRules",
    "decode_action",
    "encode_action",
    "load_domain",
]
