"""SOLID's label-free detection pretraining (docs/pretrain.md): configs, the wrapper, COCO fine-tuning."""
