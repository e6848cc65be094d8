"""Tabular Q-learning, the paper's agent: discretise observations, learn one Q-table per env."""

from modelicagym.agents.discretization import Discretizer
from modelicagym.agents.episodes import EpisodeTracker
from modelicagym.agents.qlearning import QLearningAgent, QLearningConfig
from modelicagym.agents.training import TrainingLog, train

__all__ = [
    "Discretizer",
    "EpisodeTracker",
    "QLearningAgent",
    "QLearningConfig",
    "TrainingLog",
    "train",
]
