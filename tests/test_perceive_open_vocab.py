"""The owl-sam detector end to end with tiny random OWLv2 or Grounding DINO boxes + SAM masks saved to a local folder."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from test_perceive_scenes import rendered_room
from sdovon_mj.config import PerceiveConfig
from sdovon_mj.errors import InputError
from sdovon_mj.perceive import backproject_detections, make_detector


def build_tiny_weights(root: Path) -> Path:
    """Save randomly initialised tiny OWLv2, Grounding DINO and SAM models (+ processors) as transformers folders."""
    import torch
    from transformers import (CLIPTokenizer, Owlv2Config, Owlv2ForObjectDetection, Owlv2ImageProcessorPil, Owlv2Processor,
                              SamConfig, SamImageProcessorPil, SamModel, SamProcessor)

    torch.manual_seed(0)
    vocab: dict[str, int] = {}
    for c in "abcdefghijklmnopqrstuvwxyz":
        vocab[c] = len(vocab)
        vocab[c + "</w>"] = len(vocab)
    # OWL masks queries whose first token id is 0: keep the special tokens at non-zero ids, as in CLIP.
    vocab["<|startoftext|>"] = len(vocab)
    vocab["<|endoftext|>"] = len(vocab)
    tok = CLIPTokenizer(vocab=vocab, merges=[])
    bos, eos = vocab["<|startoftext|>"], vocab["<|endoftext|>"]
    owl_cfg = Owlv2Config(
        text_config=dict(vocab_size=len(vocab), hidden_size=32, intermediate_size=37, num_hidden_layers=1, num_attention_heads=4,
                         max_position_embeddings=16, bos_token_id=bos, eos_token_id=eos, pad_token_id=eos),
        vision_config=dict(hidden_size=32, intermediate_size=37, num_hidden_layers=1, num_attention_heads=4, image_size=64, patch_size=16),
        projection_dim=32)
    owl = Owlv2ForObjectDetection(owl_cfg).eval()
    proc = Owlv2Processor(image_processor=Owlv2ImageProcessorPil(size={"height": 64, "width": 64}), tokenizer=tok)
    owl.save_pretrained(root / "owlv2")
    proc.save_pretrained(root / "owlv2")
    sam_cfg = SamConfig(
        vision_config=dict(hidden_size=32, num_hidden_layers=2, num_attention_heads=4, intermediate_size=37, image_size=64,
                           patch_size=8, output_channels=16, global_attn_indexes=[1], window_size=4, mlp_dim=37, num_pos_feats=8),
        prompt_encoder_config=dict(hidden_size=16, image_size=64, patch_size=8, mask_input_channels=4),
        mask_decoder_config=dict(hidden_size=16, num_hidden_layers=2, num_attention_heads=2, mlp_dim=32, iou_head_hidden_dim=16))
    SamModel(sam_cfg).eval().save_pretrained(root / "sam")
    SamProcessor(image_processor=SamImageProcessorPil(size={"longest_edge": 64}, pad_size={"height": 64, "width": 64})).save_pretrained(root / "sam")
    build_tiny_grounding_dino(root / "gdino")
    return root


def build_tiny_grounding_dino(folder: Path) -> Path:
    """Save a randomly initialised tiny Grounding DINO (Swin + BERT, word-level vocabulary) with its processor."""
    import torch
    from transformers import (BertTokenizer, GroundingDinoConfig, GroundingDinoForObjectDetection,
                              GroundingDinoImageProcessorPil, GroundingDinoProcessor, SwinConfig)

    torch.manual_seed(0)
    folder.mkdir(parents=True, exist_ok=True)
    words = ["[PAD]", "[UNK]", "[CLS]", "[SEP]", "[MASK]", ".", "table", "sofa", "bookshelf", "a", "the"]
    (folder / "vocab.txt").write_text("\n".join(words) + "\n")
    tok = BertTokenizer(str(folder / "vocab.txt"))
    backbone = SwinConfig(image_size=64, patch_size=4, embed_dim=8, depths=[1, 1, 1, 1], num_heads=[1, 1, 1, 1],
                          window_size=2, out_features=["stage2", "stage3", "stage4"])
    cfg = GroundingDinoConfig(
        backbone_config=backbone,
        text_config=dict(model_type="bert", vocab_size=len(words), hidden_size=32, num_hidden_layers=1, num_attention_heads=2,
                         intermediate_size=32, max_position_embeddings=64),
        d_model=32, encoder_layers=1, decoder_layers=2, encoder_attention_heads=2, decoder_attention_heads=2,  # 2 decoder layers:
        encoder_ffn_dim=32, decoder_ffn_dim=32, num_queries=10, num_feature_levels=3, encoder_n_points=2,  # box heads are tied
        decoder_n_points=2, max_text_len=32)
    GroundingDinoForObjectDetection(cfg).eval().save_pretrained(folder)
    GroundingDinoProcessor(image_processor=GroundingDinoImageProcessorPil(size={"shortest_edge": 64, "longest_edge": 96}),
                           tokenizer=tok).save_pretrained(folder)
    return folder


@pytest.fixture(scope="module")
def tiny_weights(tmp_path_factory) -> Path:
    pytest.importorskip("transformers")
    return build_tiny_weights(tmp_path_factory.mktemp("owl_sam"))


@pytest.mark.parametrize("box_folder,box_type", [("owlv2", "owlv2"), ("gdino", "grounding-dino")])
def test_owl_sam_end_to_end(tiny_weights: Path, box_folder: str, box_type: str) -> None:
    _insts, scene, obs = rendered_room()
    vocab = ("table", "sofa", "bookshelf")
    cfg = PerceiveConfig(detector="owl-sam", detector_weights=str(tiny_weights), owl_weights=box_folder, vocabulary=vocab,
                         score_threshold=0.0)
    det = make_detector(cfg, scene)
    assert det.name == "owl-sam" and det.box_type == box_type
    batches = det.detect_batch(obs[:2])
    assert len(batches) == 2
    dets = [d for b in batches for d in b]
    assert dets, "random tiny models still score every query above threshold 0"
    h, w = obs[0].depth.shape
    for d in dets:
        assert d.mask.shape == (h, w) and d.mask.dtype == bool and d.mask.any()
        assert d.label in vocab and 0.0 <= d.score <= 1.0
    # The masks flow through the rest of the stage.
    insts = backproject_detections(obs[0], batches[0], cfg)
    assert all(i.label in vocab and len(i.points) >= cfg.min_points for i in insts)


def test_missing_or_broken_weights_name_the_folder(tmp_path: Path, tiny_weights: Path) -> None:
    missing = tmp_path / "nope"
    with pytest.raises(InputError, match="nope"):
        make_detector(PerceiveConfig(detector="owl-sam", detector_weights=str(missing)))
    with pytest.raises(InputError, match="detector_weights"):
        make_detector(PerceiveConfig(detector="owl-sam"))
    broken = tmp_path / "broken"
    (broken / "owlv2").mkdir(parents=True)
    (broken / "sam").mkdir()
    (broken / "owlv2" / "config.json").write_text("{not json")
    with pytest.raises(InputError, match="owlv2"):
        make_detector(PerceiveConfig(detector="owl-sam", detector_weights=str(broken)))
    # Right configs, weights file truncated: loading fails and the error names the model folder.
    import shutil

    bad = tmp_path / "truncated"
    shutil.copytree(tiny_weights, bad)
    for f in (bad / "sam").glob("*.safetensors"):
        f.write_bytes(f.read_bytes()[:100])
    with pytest.raises(InputError, match=str(bad / "sam")):
        make_detector(PerceiveConfig(detector="owl-sam", detector_weights=str(bad)))


def test_open_vocab_imports_without_torch() -> None:
    code = ("import sys; sys.modules['torch'] = None; sys.modules['transformers'] = None\n"
            "import sdovon_mj.perceive.open_vocab as m\n"
            "from sdovon_mj.errors import InputError\n"
            "import tempfile, pathlib\n"
            "d = pathlib.Path(tempfile.mkdtemp())\n"
            "for s in ('owlv2', 'sam'):\n"
            "    (d / s).mkdir(); (d / s / 'config.json').write_text('{\"model_type\": \"%s\"}' % ('owlv2' if s == 'owlv2' else 'sam'))\n"
            "try:\n"
            "    m.OpenVocabDetector(weights=d)\n"
            "except InputError as e:\n"
            "    print('ERR', e)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert "ERR" in out.stdout and "torch" in out.stdout
