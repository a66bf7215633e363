import contextlib
import io
import json
import math
import os
import subprocess
import sys
import tempfile
import unittest
from pathlib import Path

import fixture

try:
    import torch

    from solid_data import finetune as ft
    from solid_data.detection.coco import STAT_NAMES, CocoDetection
    from solid_data.detection.config import build_detector, load_config
except ImportError as error:
    raise unittest.SkipTest(f"PyTorch or torchvision is not importable: {error}")

REPO = Path(__file__).resolve().parents[3]
# Tiny on purpose: the fixture's 96x72 images at their own size, few sampled RoIs.
OVERRIDES = {"min_size": 72, "max_size": 96, "num_workers": 0, "rpn_batch_size_per_image": 64,
             "box_batch_size_per_image": 64}


def pycocotools_path(scratch: Path) -> str | None:
    """A directory to put on sys.path for pycocotools (None when it is importable already);
    SkipTest when there is neither pycocotools nor a cocoapi source to build it from."""
    given = os.environ.get("SOLID_PYCOCOTOOLS")
    if given:
        return given
    try:
        import pycocotools.cocoeval  # noqa: F401
        return None
    except ImportError:
        pass
    done = subprocess.run([str(REPO / "scripts" / "build-pycocotools.sh"), os.environ.get(
        "SOLID_COCOAPI", str(REPO.parent / "shared" / "third_party" / "cocoapi")), str(scratch / "pycocotools")],
        capture_output=True, text=True)
    if done.returncode == 2:
        raise unittest.SkipTest(f"pycocotools is not importable and cannot be built: {done.stderr.strip()}")
    if done.returncode != 0:
        raise RuntimeError(f"scripts/build-pycocotools.sh exited with {done.returncode}:\n{done.stderr}")
    return done.stdout.strip().splitlines()[-1]


class FinetuneTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.scratch = tempfile.TemporaryDirectory(prefix="solid-finetune-")
        cls.dir = Path(cls.scratch.name)
        cls.coco_path = pycocotools_path(cls.dir)
        if cls.coco_path and cls.coco_path not in sys.path:
            sys.path.insert(0, cls.coco_path)
        dataset = fixture.dataset_dir()
        done = subprocess.run([os.environ["SOLID_BINARY"], "export", "coco", str(dataset), str(cls.dir / "coco"),
                               "--categories", "model", "--masks", "visible"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        if done.returncode != 0:
            raise RuntimeError(f"solid export coco exited with {done.returncode}:\n{done.stderr}")
        cls.json = cls.dir / "coco" / "annotations.json"
        cls.images = cls.dir / "coco" / "images"
        cls.categories = len(json.loads(cls.json.read_text())["categories"])
        cls.config = load_config("small", OVERRIDES)

    @classmethod
    def tearDownClass(cls):
        if cls.coco_path in sys.path:
            sys.path.remove(cls.coco_path)
        cls.scratch.cleanup()

    def run_finetune(self, name, **options):
        values = dict(train_json=self.json, train_images=self.images, val_json=self.json, val_images=self.images,
                      out=self.dir / name, iterations=2, batch=2, warmup=1, seed=3, threads=1,
                      overrides=OVERRIDES, log=None)
        values.update(options)
        return ft.finetune(ft.FinetuneOptions(**values))

    def exported(self, config, path):
        """A stand-in for a pretraining run's detector.pth: every key but the predictor's."""
        state = {k: v for k, v in build_detector(config, num_classes=2).state_dict().items()
                 if not k.startswith(ft.PREDICTOR_PREFIXES)}
        torch.save(state, path)
        return path

    def test_labels_are_contiguous_and_flips_follow_the_seed(self):
        data = json.loads(self.json.read_text())
        plain = CocoDetection(self.json, self.images)
        self.assertEqual(plain.num_categories, self.categories)
        labels = torch.cat([plain[i][1]["labels"] for i in range(len(plain))])
        self.assertEqual(sorted(set(labels.tolist())), list(range(1, self.categories + 1)))
        first = plain[0][1]
        expected = sorted([a["bbox"][0], a["bbox"][1], a["bbox"][0] + a["bbox"][2], a["bbox"][1] + a["bbox"][3]]
                          for a in data["annotations"] if a["image_id"] == first["image_id"])
        self.assertEqual(sorted(first["boxes"].tolist()), expected)

        def flips(seed, epoch):
            ds = CocoDetection(self.json, self.images, flip_probability=0.5, seed=seed)
            ds.set_epoch(epoch)
            out = []
            for i in range(len(ds)):
                image, target = ds[i]
                out.append(not torch.equal(image, plain[i][0]))
                if out[-1]:
                    self.assertTrue(torch.equal(image, plain[i][0].flip(-1)))
                    width = image.shape[-1]
                    b = plain[i][1]["boxes"]
                    self.assertTrue(torch.equal(target["boxes"], torch.stack(
                        [width - b[:, 2], b[:, 1], width - b[:, 0], b[:, 3]], dim=1)))
            return out

        self.assertEqual(flips(1, 0), flips(1, 0))
        self.assertTrue(any(flips(1, 0)) and not all(flips(1, 0)))
        self.assertNotEqual(flips(1, 0), flips(1, 1))

    def test_metrics_and_same_seed_same_losses(self):
        report = self.run_finetune("a")
        metrics = json.loads((self.dir / "a" / "metrics.json").read_text())
        for name in STAT_NAMES:
            value = metrics[name]
            self.assertTrue(math.isfinite(value) and (0.0 <= value <= 1.0 or value == -1.0), f"{name} = {value}")
        self.assertEqual((metrics["iterations"], metrics["init"], metrics["seed"]), (2, None, 3))
        self.assertEqual(len(report.losses), 2)
        again = self.run_finetune("b")
        self.assertEqual(report.losses[0]["loss"], again.losses[0]["loss"])
        self.assertEqual(report.losses, again.losses)
        other = self.run_finetune("c", seed=4, iterations=1)
        self.assertNotEqual(report.losses[0]["loss"], other.losses[0]["loss"])

    def test_init_loads_all_but_the_predictor(self):
        path = self.exported(self.config, self.dir / "detector.pth")
        model = build_detector(self.config, num_classes=self.categories + 1)
        ft.load_init(model, path)
        saved = torch.load(path)
        for key, value in model.state_dict().items():
            if key in saved:
                self.assertTrue(torch.equal(value, saved[key]), key)
        report = self.run_finetune("init", init=path, iterations=1)
        self.assertEqual(report.metrics["init"], str(path))

    def test_init_of_another_config_is_refused(self):
        other = self.exported(load_config("small", {**OVERRIDES, "detector": "fasterrcnn_resnet50_fpn"}),
                              self.dir / "r50.pth")
        with self.assertRaisesRegex(ft.FinetuneError, "wrong config for this checkpoint"):
            ft.load_init(build_detector(self.config, num_classes=3), other)
        # A key short: not an export of this config either.
        partial = self.dir / "partial.pth"
        state = torch.load(self.exported(self.config, partial))
        state.pop(next(iter(state)))
        torch.save(state, partial)
        with self.assertRaisesRegex(ft.FinetuneError, "wrong config for this checkpoint"):
            ft.load_init(build_detector(self.config, num_classes=3), partial)

    def test_clear_errors(self):
        no_categories = self.dir / "no-categories.json"
        data = json.loads(self.json.read_text())
        no_categories.write_text(json.dumps({**data, "categories": []}))
        base = ["--train-json", str(self.json), "--train-images", str(self.images), "--val-json", str(self.json),
                "--val-images", str(self.images), "--iterations", "1", "--out", str(self.dir / "err")]
        cases = [
            (["--train-json", str(self.dir / "absent.json")], "absent.json: no such annotations file"),
            (["--val-images", str(self.dir / "absent")], "absent: no such images directory"),
            (["--train-json", str(no_categories)], "no categories"),
            (["--config", "tiny"], "no such config file"),
            (["--set", "min_sise=72"], "unknown config key 'min_sise'"),
            (["--init", str(self.dir / "absent.pth")], "no such file"),
        ]
        for extra, message in cases:
            stderr = io.StringIO()
            with contextlib.redirect_stderr(stderr):
                self.assertEqual(ft.main(base + extra), 2, extra)
            self.assertIn(message, stderr.getvalue())
            self.assertTrue(stderr.getvalue().startswith("finetune: "), stderr.getvalue())
        # The module runs as a command and says what is wrong without a traceback.
        done = subprocess.run([sys.executable, "-m", "solid_data.finetune", *base, "--config", "tiny"],
                              capture_output=True, text=True)
        self.assertEqual(done.returncode, 2)
        self.assertIn("no such config file", done.stderr)
        self.assertNotIn("Traceback", done.stderr)


if __name__ == "__main__":
    unittest.main()
