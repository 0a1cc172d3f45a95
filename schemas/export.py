"""The JSON Schema of every message, exported beside the models for dashboards not written in Python.

``python -m stiction.schemas.export`` rewrites ``schemas/json/``; a test checks the files are current.
"""

from __future__ import annotations

import json
from pathlib import Path

from stiction.schemas.diagnosis import DiagnosisReport
from stiction.schemas.loop_file import LoopFile
from stiction.schemas.messages import AgentHealth, BridgeHealth, LoopTruth, SampleBatch
from stiction.schemas.model_card import ModelCard
from stiction.schemas.report import StictionReport

MODELS = {
    "sample_batch": SampleBatch,
    "loop_truth": LoopTruth,
    "agent_health": AgentHealth,
    "bridge_health": BridgeHealth,
    "loop_file": LoopFile,
    "stiction_report": StictionReport,
    "model_card": ModelCard,
    "diagnosis_report": DiagnosisReport,
}
JSON_DIR = Path(__file__).resolve().parent / "json"


def schemas() -> dict[str, str]:
    return {
        f"{name}.schema.json": json.dumps(model.model_json_schema(), indent=2, sort_keys=True) + "\n"
        for name, model in MODELS.items()
    }


def main() -> None:
    JSON_DIR.mkdir(exist_ok=True)
    for name, text in schemas().items():
        (JSON_DIR / name).write_text(text)
        print(JSON_DIR / name)


if __name__ == "__main__":
    main()
