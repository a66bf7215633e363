"""SOLID's pretraining wrapper (docs/solid-method.md 6) on a torchvision Faster or Mask R-CNN.

The *target detector* is the config's torchvision detector whose classifier is replaced by a
256-d embedding per RoI (`EmbeddingPredictor`), with class-agnostic box regression and mask
head (`TargetRoIHeads`). The *query encoder* is a momentum copy of its backbone, box head and
embedding (parameters only, normalising each query batch by its own statistics as the
reference's default does; or EMAN, statistics averaged too): RoIAlign over each query's whole
unpadded box, the two FC layers of 1024, the linear embedding. A *memory bank*
holds one embedding per model; each step writes the step's query embeddings into it, gathered
over ranks and de-duplicated by model, and every foreground RoI is classified against all of
its entries (InfoNCE at temperature tau).

The losses are normalised over the union batch of all ranks (foreground RoIs for L_con, sampled
RoIs for the box regression, sampled anchors for the RPN), so that N ranks give one rank's
numbers on their union; only Mask R-CNN's mask loss keeps torchvision's mean over one rank.
"""

from __future__ import annotations

import copy
from typing import Any

import torch
import torch.distributed as dist
import torch.nn.functional as F
from torch import nn
from torchvision.models.detection.mask_rcnn import MaskRCNNPredictor
from torchvision.models.detection.roi_heads import RoIHeads, maskrcnn_loss
from torchvision.models.detection.rpn import RegionProposalNetwork
from torchvision.models.detection.transform import GeneralizedRCNNTransform

from .config import build_detector

__all__ = ["EmbeddingPredictor", "UnionRPN", "TargetRoIHeads", "SolidWrapper", "PREDICTOR_PREFIXES",
           "export_state_dict", "world"]

# The keys a fine-tuning model does not take from pretraining: its classifier and box
# regressor (and the mask head's per-class logits), which depend on its categories.
PREDICTOR_PREFIXES = ("roi_heads.box_predictor.", "roi_heads.mask_predictor.mask_fcn_logits.")


def world() -> tuple[int, int]:
    """(rank, world size); (0, 1) outside torch.distributed."""
    if dist.is_available() and dist.is_initialized():
        return dist.get_rank(), dist.get_world_size()
    return 0, 1


def _global_sum(value: torch.Tensor) -> torch.Tensor:
    if world()[1] > 1:
        value = value.clone()
        dist.all_reduce(value)
    return value


class EmbeddingPredictor(nn.Module):
    """In place of FastRCNNPredictor: an embedding of each RoI instead of class scores, and one
    class-agnostic box delta."""

    def __init__(self, in_channels: int, embedding_dim: int):
        super().__init__()
        self.embed = nn.Linear(in_channels, embedding_dim)
        self.bbox_pred = nn.Linear(in_channels, 4)

    def forward(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        x = x.flatten(start_dim=1)
        return self.embed(x), self.bbox_pred(x)


class _StoredSize(GeneralizedRCNNTransform):
    """Normalises and batches but never resizes: `PretrainDataset` already resized each target
    (with its boxes recomputed from the resized masks), as Detectron2's mapper does."""

    def resize(self, image, target=None):
        return image, target


class UnionRPN(RegionProposalNetwork):
    """torchvision's RPN with its losses normalised over the sampled anchors of every rank:
    its own mean over one rank's anchors would weigh a rank's anchors by that rank's count."""

    @classmethod
    def like(cls, rpn: RegionProposalNetwork) -> "UnionRPN":
        union = cls(rpn.anchor_generator, rpn.head, rpn.proposal_matcher.high_threshold,
                    rpn.proposal_matcher.low_threshold, rpn.fg_bg_sampler.batch_size_per_image,
                    rpn.fg_bg_sampler.positive_fraction, rpn._pre_nms_top_n, rpn._post_nms_top_n, rpn.nms_thresh,
                    rpn.score_thresh)
        union.min_size = rpn.min_size
        return union

    def compute_loss(self, objectness, pred_bbox_deltas, labels, regression_targets):
        positive, negative = self.fg_bg_sampler(labels)
        positive = torch.where(torch.cat(positive))[0]
        sampled = torch.cat([positive, torch.where(torch.cat(negative))[0]])
        labels = torch.cat(labels)
        _, size = world()
        count = _global_sum(torch.tensor([sampled.numel()], dtype=torch.float64, device=objectness.device))
        count = count[0].clamp(min=1)
        scale = size / count.to(objectness.dtype)
        box_sum = F.smooth_l1_loss(pred_bbox_deltas[positive], torch.cat(regression_targets)[positive], beta=1 / 9,
                                   reduction="sum")
        objectness_sum = F.binary_cross_entropy_with_logits(objectness.flatten()[sampled], labels[sampled],
                                                            reduction="sum")
        return objectness_sum * scale, box_sum * scale


class TargetRoIHeads(RoIHeads):
    """torchvision's RoIHeads in training, with L_con in place of the classification loss.

    Target labels are bank indices plus one (0 is background). ``bank`` is set by the wrapper
    before each forward: the L2-normalised embeddings of every model.
    """

    bank: torch.Tensor
    temperature: float

    def forward(self, features, proposals, image_shapes, targets=None):
        if not self.training or targets is None:
            raise RuntimeError("the target detector of the wrapper only trains; fine-tune an exported model to detect")
        proposals, matched_idxs, labels, regression_targets = self.select_training_samples(proposals, targets)
        box_features = self.box_head(self.box_roi_pool(features, proposals, image_shapes))
        embeddings, deltas = self.box_predictor(box_features)
        labels_all = torch.cat(labels)
        regression_all = torch.cat(regression_targets)
        foreground = torch.where(labels_all > 0)[0]
        _, size = world()
        counts = _global_sum(torch.tensor([foreground.numel(), labels_all.numel()], dtype=torch.float64,
                                          device=embeddings.device))
        keys = F.normalize(embeddings[foreground], dim=1)
        logits = keys @ self.bank.t() / self.temperature
        con_sum = F.cross_entropy(logits, labels_all[foreground] - 1, reduction="sum")
        box_sum = F.smooth_l1_loss(deltas[foreground], regression_all[foreground], beta=1 / 9, reduction="sum")
        # Each rank's share of the union batch's mean, times the world size because DDP
        # averages gradients over ranks.
        losses = {
            "loss_con": con_sum * size / counts[0].clamp(min=1).to(con_sum.dtype),
            "loss_box_reg": box_sum * size / counts[1].clamp(min=1).to(box_sum.dtype),
        }
        if self.has_mask():
            positive = [torch.where(image_labels > 0)[0] for image_labels in labels]
            mask_proposals = [p[i] for p, i in zip(proposals, positive)]
            mask_matched = [m[i] for m, i in zip(matched_idxs, positive)]
            mask_logits = self.mask_predictor(self.mask_head(self.mask_roi_pool(features, mask_proposals,
                                                                                image_shapes)))
            # One class-agnostic mask channel: every instance reads channel 0.
            zeros = [torch.zeros_like(t["labels"]) for t in targets]
            losses["loss_mask"] = maskrcnn_loss(mask_logits, mask_proposals, [t["masks"] for t in targets], zeros,
                                                mask_matched)
        return [], losses


class _QueryEncoder(nn.Module):
    """The momentum copy: backbone, box head and embedding of the target detector.

    ``query_norm`` "batch" (SOLID's reference code): its BatchNorm normalises by each query
    batch's statistics and only parameters are averaged. "eman": always in eval mode, its
    statistics averaged with the parameters (EMAN); from fresh statistics every query embeds
    alike (a standard deviation of 3e-9 over 16 queries at the start) until the average has
    caught up, thousands of iterations at 0.999.
    """

    def __init__(self, target: nn.Module, query_norm: str):
        super().__init__()
        self.eman = query_norm == "eman"
        self.backbone = copy.deepcopy(target.backbone)
        self.box_head = copy.deepcopy(target.roi_heads.box_head)
        self.embed = copy.deepcopy(target.roi_heads.box_predictor.embed)
        for p in self.parameters():
            p.requires_grad_(False)
        self.train(not self.eman)

    def train(self, mode: bool = True):
        return super().train(mode and not self.eman)


class SolidWrapper(nn.Module):
    """Target detector, query encoder and memory bank of ``num_models`` entries."""

    def __init__(self, config: dict[str, Any], num_models: int):
        super().__init__()
        self.config = config
        self.momentum = config["momentum"]
        target = build_detector(config, num_classes=2)
        heads = target.roi_heads
        representation = heads.box_head.fc7.out_features
        predictor = EmbeddingPredictor(representation, config["embedding_dim"])
        roi_heads = TargetRoIHeads(
            heads.box_roi_pool, heads.box_head, predictor,
            0.5, 0.5,  # foreground and background IoU thresholds, torchvision's
            config["box_batch_size_per_image"], config["box_positive_fraction"],
            bbox_reg_weights=None, score_thresh=0.05, nms_thresh=0.5, detections_per_img=100)
        roi_heads.temperature = config["temperature"]
        if heads.has_mask():
            roi_heads.mask_roi_pool = heads.mask_roi_pool
            roi_heads.mask_head = heads.mask_head
            roi_heads.mask_predictor = MaskRCNNPredictor(heads.mask_predictor.conv5_mask.in_channels,
                                                         heads.mask_predictor.conv5_mask.out_channels, 1)
        target.roi_heads = roi_heads
        target.rpn = UnionRPN.like(target.rpn)
        t = target.transform
        target.transform = _StoredSize(t.min_size, t.max_size, t.image_mean, t.image_std,
                                       size_divisible=t.size_divisible)
        self.target = target
        self.query = _QueryEncoder(target, config["query_norm"])
        generator = torch.Generator().manual_seed(int(config["seed"]))
        bank = torch.randn(num_models, config["embedding_dim"], generator=generator)
        self.register_buffer("bank", F.normalize(bank, dim=1))

    @torch.no_grad()
    def momentum_update(self) -> None:
        """k <- m k + (1 - m) q over every parameter (and, with EMAN, every statistic; batch
        counters copied)."""
        heads = self.target.roi_heads
        for source, copy_ in ((self.target.backbone, self.query.backbone), (heads.box_head, self.query.box_head),
                              (heads.box_predictor.embed, self.query.embed)):
            if self.query.eman:
                pairs = zip(source.state_dict().values(), copy_.state_dict().values())
            else:
                pairs = zip(source.parameters(), copy_.parameters())
            for value, averaged in pairs:
                if not averaged.is_floating_point():
                    averaged.copy_(value)
                else:
                    averaged.mul_(self.momentum).add_(value.detach(), alpha=1.0 - self.momentum)

    @torch.no_grad()
    def encode_queries(self, images: torch.Tensor, sizes: torch.Tensor) -> torch.Tensor:
        """L2-normalised embeddings of uint8 query images (Q x 3 x S x S, each padded to S x S;
        ``sizes`` holds each one's unpadded height and width)."""
        x = self.target.transform.normalize(images.float() / 255.0) if images.numel() else images.float()
        side = (images.shape[-2], images.shape[-1])
        features = self.query.backbone(x)
        boxes = [torch.tensor([[0.0, 0.0, float(w), float(h)]], device=images.device) for h, w in sizes.tolist()]
        pooled = self.target.roi_heads.box_roi_pool(features, boxes, [side] * len(boxes))
        return F.normalize(self.query.embed(self.query.box_head(pooled).flatten(start_dim=1)), dim=1)

    @torch.no_grad()
    def update_bank(self, embeddings: torch.Tensor, model_ids: torch.Tensor) -> torch.Tensor:
        """Writes each model's embedding, gathered over ranks in rank order, the first one of a
        model that several queries show. Returns the model ids written."""
        embeddings, model_ids = _gather_queries(embeddings, model_ids)
        keep = model_ids >= 0
        embeddings, model_ids = embeddings[keep], model_ids[keep]
        if model_ids.numel() == 0:
            return model_ids
        sorted_ids, order = torch.sort(model_ids, stable=True)
        starts = torch.ones_like(sorted_ids, dtype=torch.bool)
        starts[1:] = sorted_ids[1:] != sorted_ids[:-1]
        first = order[starts]
        self.bank[model_ids[first]] = embeddings[first].to(self.bank.dtype)
        return model_ids[first]

    def forward(self, batch: dict, model_ids: torch.Tensor, target_detector: nn.Module | None = None):
        """One training step's losses. ``model_ids``: the bank index of each of the batch's
        queries; ``target_detector``: the DDP-wrapped target detector when distributed."""
        self.momentum_update()
        queries = self.encode_queries(batch["query_images"], batch["query_sizes"])
        self.update_bank(queries, model_ids)
        self.target.roi_heads.bank = self.bank.clone()
        images, targets = [], []
        for t in batch["targets"]:
            images.append(t["image"].float() / 255.0)
            target = {"boxes": t["boxes"], "labels": model_ids[t["query_index"]] + 1}
            if self.target.roi_heads.has_mask():
                target["masks"] = t["masks"].to(torch.uint8)
            targets.append(target)
        return (target_detector or self.target)(images, targets)


def _gather_queries(embeddings: torch.Tensor, model_ids: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Every rank's query embeddings and model ids, concatenated in rank order (ranks may hold
    different counts: padded with id -1 for the collective)."""
    _, size = world()
    if size == 1:
        return embeddings, model_ids
    count = torch.tensor([model_ids.numel()], device=model_ids.device)
    counts = [torch.zeros_like(count) for _ in range(size)]
    dist.all_gather(counts, count)
    most = int(max(c.item() for c in counts))
    padded_ids = torch.full((most,), -1, dtype=torch.int64, device=model_ids.device)
    padded_ids[:model_ids.numel()] = model_ids
    padded = torch.zeros((most, embeddings.shape[1]), dtype=embeddings.dtype, device=embeddings.device)
    padded[:embeddings.shape[0]] = embeddings
    all_ids = [torch.empty_like(padded_ids) for _ in range(size)]
    all_embeddings = [torch.empty_like(padded) for _ in range(size)]
    dist.all_gather(all_ids, padded_ids)
    dist.all_gather(all_embeddings, padded)
    return torch.cat(all_embeddings), torch.cat(all_ids)


def export_state_dict(wrapper: SolidWrapper) -> dict[str, torch.Tensor]:
    """The target detector minus its embedding classifier and box regressor, under the keys of
    ``build_detector(config, K)`` (any K): the fine-tuning model's start. Statistics a frozen
    normalisation lacks (BatchNorm's batch counters) come from a fresh model."""
    template = build_detector({**wrapper.config, "norm": "batch"}, num_classes=2).state_dict()
    trained = wrapper.target.state_dict()
    out = {}
    for key, fresh in template.items():
        if key.startswith(PREDICTOR_PREFIXES):
            continue
        value = trained.get(key, fresh)
        if value.shape != fresh.shape:
            raise RuntimeError(f"pretrained {key} has shape {tuple(value.shape)}, the torchvision model "
                               f"{tuple(fresh.shape)}")
        out[key] = value.detach().cpu().clone()
    return out
