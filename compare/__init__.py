"""rtval's judge and the applications built on it.

Rooms by feature (docs/architecture.md): `judge` (pure: images, metrics, effect masks,
exact match, tolerances, scores, rubric, target models), `render` (running and caching
renderers), `diagnose` (why an image differs: its function `compare.diagnose.diagnose`),
`verdict`, `check`, `report`, `grading`, `stress` (the applications), `sandbox`, `pages`, and
`cli` (the `rtval` command line).

The public API below is what another program needs to judge images as rtval does.
"""

from compare.diagnose import Diagnosis
from compare.diagnose.candidate import Candidate
from compare.diagnose.mistakes import Mistake, catalogue
from compare.judge.effects import EFFECTS, effect_masks
from compare.judge.evaluate import EffectResult, Evaluation, ExactInputs, evaluate_pair
from compare.judge.exact_match import ExactMatch, exact_match
from compare.judge.images import Image, ImageError, read_image, write_exr
from compare.judge.metrics import Maps, Metrics, SizeMismatch, compute_maps, compute_metrics
from compare.judge.png import write_png
from compare.judge.rubric import Rubric, RubricError, load_rubric, parse_rubric
from compare.judge.scoring import EffectRule, EffectScore, Score, score_effects
from compare.judge.tolerances import Tolerances, Verdict

__all__ = [
    "EFFECTS",
    "Candidate",
    "Diagnosis",
    "EffectResult",
    "EffectRule",
    "EffectScore",
    "Evaluation",
    "ExactInputs",
    "ExactMatch",
    "Image",
    "ImageError",
    "Maps",
    "Metrics",
    "Mistake",
    "Rubric",
    "RubricError",
    "Score",
    "SizeMismatch",
    "Tolerances",
    "Verdict",
    "catalogue",
    "compute_maps",
    "compute_metrics",
    "effect_masks",
    "evaluate_pair",
    "exact_match",
    "load_rubric",
    "parse_rubric",
    "read_image",
    "score_effects",
    "write_exr",
    "write_png",
]
