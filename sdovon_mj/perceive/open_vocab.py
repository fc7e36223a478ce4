"""Open-vocabulary detector `owl-sam`: OWLv2 (or Grounding DINO) boxes from text prompts, SAM masks.

Weights load only from a local folder (``perceive.detector_weights``) holding two transformers
``save_pretrained`` folders: ``<weights>/<owl_weights>`` (an OWLv2/OWL-ViT or Grounding DINO model
with its processor) and ``<weights>/<sam_weights>`` (a SAM model with its processor). Nothing is
downloaded. torch and transformers are imported only when the detector is built, so this module
imports without them.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from ..config import AgentConfig, PerceiveConfig
from ..errors import InputError
from ..records import Detection, Observation, SceneAsset
from .detectors import BaseDetector, default_vocabulary


def _model_type(folder: Path) -> str:
    """Return the `model_type` of a transformers model folder, or raise InputError naming it."""
    cfg = folder / "config.json"
    if not folder.is_dir():
        raise InputError(folder, "weights folder not found")
    if not cfg.is_file():
        raise InputError(folder, "no config.json: not a transformers model folder (save_pretrained output expected)")
    try:
        data = json.loads(cfg.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise InputError(cfg, f"unreadable model config: {e}") from None
    mt = data.get("model_type", "") if isinstance(data, dict) else ""
    if not mt:
        raise InputError(cfg, "model config has no model_type")
    return str(mt)


class OpenVocabDetector(BaseDetector):
    """Text-prompted boxes (OWLv2 / Grounding DINO) refined to masks by SAM, all via transformers."""

    name = "owl-sam"
    BOX_MODELS = ("owlv2", "owlvit", "grounding-dino", "mm-grounding-dino")

    def __init__(self, cfg: PerceiveConfig | None = None, scene: SceneAsset | None = None, seed: int = 0,
                 weights: str | Path | None = None, vocabulary: tuple[str, ...] | list[str] | None = None,
                 device: str = "cpu", max_detections: int = 50, agent: AgentConfig | None = None) -> None:
        """Load the box and mask models from a local weights folder (nothing is downloaded).

        Parameters
        ----------
        cfg : PerceiveConfig, optional
            Perceive settings (weights folders, score threshold).
        scene : SceneAsset, optional
            Unused (the detector sees images only); part of the detector plugin call.
        seed : int
            Unused; part of the detector plugin call.
        weights : str or Path, optional
            Local folder with the box and SAM weights (default: ``cfg.detector_weights``).
        vocabulary : tuple or list of str, optional
            Text prompts (default: the config's vocabulary).
        device : str
            Torch device.
        max_detections : int
            Most detections kept per image.
        agent : AgentConfig, optional
            Unused; part of the detector plugin call.
        """
        # `agent` is part of the detector plugin call (make_detector); only the gt detector reads it (eta_gt)
        cfg = cfg or PerceiveConfig()
        root = str(weights if weights is not None else cfg.detector_weights)
        if not root:
            raise InputError("perceive.detector_weights", "the owl-sam detector needs a local weights folder (nothing is downloaded)")
        self.root = Path(root)
        if not self.root.is_dir():
            raise InputError(self.root, "detector weights folder not found")
        self.vocabulary = tuple(vocabulary) if vocabulary else default_vocabulary(cfg)
        if not self.vocabulary:
            raise ValueError("the open-vocabulary detector needs at least one text prompt")
        self.threshold = float(cfg.score_threshold)
        self.device = device
        self.max_detections = int(max_detections)
        self.box_dir = self.root / cfg.owl_weights
        self.sam_dir = self.root / cfg.sam_weights
        self.box_type = _model_type(self.box_dir)
        if self.box_type not in self.BOX_MODELS:
            raise InputError(self.box_dir, f"model_type {self.box_type!r} is not a box model ({', '.join(self.BOX_MODELS)})")
        sam_type = _model_type(self.sam_dir)
        if sam_type != "sam":
            raise InputError(self.sam_dir, f"model_type {sam_type!r} is not a SAM model")
        self._load()

    def _load(self) -> None:
        """Load processors and models from the local folders (InputError naming the folder on failure)."""
        try:
            import torch  # noqa: F401
            import transformers
        except ImportError as e:
            raise InputError(self.root, f"the owl-sam detector needs torch and transformers: {e}") from None
        for folder, what in ((self.box_dir, "box"), (self.sam_dir, "mask")):
            try:
                proc = transformers.AutoProcessor.from_pretrained(str(folder), local_files_only=True)
                if what == "box":
                    model = transformers.AutoModelForZeroShotObjectDetection.from_pretrained(str(folder), local_files_only=True)
                    self.box_processor, self.box_model = proc, model.to(self.device).eval()
                else:
                    model = transformers.SamModel.from_pretrained(str(folder), local_files_only=True)
                    self.sam_processor, self.sam_model = proc, model.to(self.device).eval()
            except InputError:
                raise
            except Exception as e:  # corrupt or incomplete folders raise many kinds of errors
                raise InputError(folder, f"cannot load the {what} model: {type(e).__name__}: {e}") from None

    def _boxes(self, image: Any, h: int, w: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return boxes (n, 4) xyxy pixels, scores (n,) and vocabulary indices (n,) for one image."""
        import torch

        prompts = list(self.vocabulary)
        if self.box_type in ("owlv2", "owlvit"):
            # Text is tokenized to the model's text length (OWL: 16 tokens), padded and truncated.
            max_len = int(self.box_model.config.text_config.max_position_embeddings)
            inputs = dict(self.box_processor.tokenizer([f"a photo of a {p}" for p in prompts], padding="max_length",
                                                       truncation=True, max_length=max_len, return_tensors="pt"))
            inputs["pixel_values"] = self.box_processor.image_processor(images=image, return_tensors="pt")["pixel_values"]
            with torch.no_grad():
                out = self.box_model(**{k: v.to(self.device) for k, v in inputs.items()})
            # OWLv2 pads images to a square at the bottom/right: boxes are relative to that square.
            side = max(h, w) if self.box_type == "owlv2" else None
            sizes = [(side, side)] if side else [(h, w)]
            res = self.box_processor.post_process_grounded_object_detection(out, threshold=self.threshold, target_sizes=sizes)[0]
            labels = res["labels"].cpu().numpy().astype(np.int64)
        else:
            text = " ".join(f"{p}." for p in prompts)
            inputs = self.box_processor(images=image, text=text, return_tensors="pt")
            with torch.no_grad():
                out = self.box_model(**{k: v.to(self.device) for k, v in inputs.items()})
            res = self.box_processor.post_process_grounded_object_detection(
                out, inputs["input_ids"], threshold=self.threshold, text_threshold=self.threshold, target_sizes=[(h, w)])[0]
            names = res.get("text_labels") or res.get("labels") or []
            labels = np.array([_closest_prompt(str(n), prompts) for n in names], dtype=np.int64)
        boxes = res["boxes"].cpu().numpy().astype(np.float64).reshape(-1, 4)
        scores = res["scores"].cpu().numpy().astype(np.float64).reshape(-1)
        order = np.argsort(-scores, kind="stable")[: self.max_detections]
        boxes, scores, labels = boxes[order], scores[order], labels[order]
        boxes[:, [0, 2]] = np.clip(boxes[:, [0, 2]], 0, w - 1)
        boxes[:, [1, 3]] = np.clip(boxes[:, [1, 3]], 0, h - 1)
        boxes[:, 2] = np.maximum(boxes[:, 2], boxes[:, 0] + 1)  # SAM needs boxes of positive size
        boxes[:, 3] = np.maximum(boxes[:, 3], boxes[:, 1] + 1)
        return boxes, scores, labels

    def _masks(self, image: Any, boxes: np.ndarray) -> np.ndarray:
        """Return SAM masks (n, H, W) bool for box prompts."""
        import torch

        inputs = self.sam_processor(images=image, input_boxes=[boxes.tolist()], return_tensors="pt")
        with torch.no_grad():
            out = self.sam_model(**{k: v.to(self.device) for k, v in inputs.items()}, multimask_output=False)
        masks = self.sam_processor.post_process_masks(out.pred_masks.cpu(), inputs["original_sizes"].cpu(),
                                                      inputs["reshaped_input_sizes"].cpu())[0]
        return masks[:, 0].numpy().astype(bool)

    def detect(self, obs: Observation) -> list[Detection]:
        """Return the prompted objects found in one RGB image, with SAM masks."""
        from PIL import Image

        rgb = np.asarray(obs.rgb, dtype=np.uint8)
        h, w = rgb.shape[:2]
        image = Image.fromarray(rgb)
        boxes, scores, labels = self._boxes(image, h, w)
        if len(boxes) == 0:
            return []
        masks = self._masks(image, boxes)
        out = []
        for m, s, lab in zip(masks, scores, labels):
            if m.any():
                out.append(Detection(mask=m, label=self.vocabulary[int(lab)], score=float(s), view_id=int(obs.view_id)))
        return out


def _closest_prompt(name: str, prompts: list[str]) -> int:
    """Return the index of the prompt a Grounding DINO phrase refers to."""
    name = name.strip().lower()
    for i, p in enumerate(prompts):
        if name == p.lower():
            return i
    for i, p in enumerate(prompts):
        if p.lower() in name or name in p.lower():
            return i
    return 0
