"""The original scene config's `logging` section."""

from __future__ import annotations

import pytest

from harness.events import (
    JsonLinesSink,
    LoggerConfigError,
    SeqSink,
    SinkSpec,
    logging_config_from_scene,
)

ORIGINAL = {
    "enable": True,
    "frequency": 1,
    "destination": {"type": "Seq", "endpoint": "http://localhost:5341"},
}


def test_original_section_is_honoured():
    config = logging_config_from_scene(ORIGINAL)
    assert config.enable
    assert config.frequency_hz == 1.0
    (spec,) = config.destinations
    assert spec.name == "seq"
    assert dict(spec.options) == {"endpoint": "http://localhost:5341"}
    (sink,) = config.create_sinks()
    try:
        assert isinstance(sink, SeqSink)
        assert sink.url == "http://localhost:5341/ingest/clef"
    finally:
        sink.close()


def test_api_key_frequency_and_disable():
    config = logging_config_from_scene(
        {
            "frequency": 25.5,
            "destination": {"type": "seq", "endpoint": "https://seq:5341", "apiKey": "k"},
        }
    )
    assert config.frequency_hz == 25.5
    assert dict(config.destinations[0].options)["api_key"] == "k"
    off = logging_config_from_scene({**ORIGINAL, "enable": False})
    assert off.create_sinks() == []


def test_superset_list_of_destinations(tmp_path):
    config = logging_config_from_scene(
        {"destination": [{"type": "jsonl", "path": str(tmp_path / "e.jsonl")}]}
    )
    (sink,) = config.create_sinks()
    assert isinstance(sink, JsonLinesSink)
    sink.close()


@pytest.mark.parametrize(
    ("section", "where"),
    [
        ([], r"^logging: \[\] is not of type object"),
        ({"enable": "yes"}, r"^logging\.enable: \"yes\" is not of type boolean"),
        ({"frequency": "1"}, r"^logging\.frequency: \"1\" is not of type number"),
        ({"frequency": 0}, r"^logging\.frequency: "),
        ({"frequency": True}, r"^logging\.frequency: "),
        ({"frequency": float("nan")}, r"^logging\.frequency: "),
        ({"colour": 1}, r"^logging\.colour: unknown key"),
        ({"destination": {"endpoint": "x"}}, r"^logging\.destination: missing required key 'type'"),
        ({"destination": {"type": "Kafka"}}, r"^logging\.destination\.type: unknown sink"),
        (
            {"destination": {"type": "Seq", "endpoint": "ftp://h"}},
            r"^logging\.destination\.endpoint: \"ftp://h\" does not match",
        ),
        (
            {"destination": {"type": "Seq", "apiKey": 5}},
            r"^logging\.destination\.apiKey: 5 is not of type string",
        ),
        (
            {"destination": {"type": "Seq", "port": 5}},
            r"^logging\.destination\.port: unknown key",
        ),
        (
            {"destination": [{"type": "Seq"}, "seq"]},
            r"^logging\.destination\[1\]: \"seq\" is not of type object",
        ),
    ],
)
def test_bad_values_name_the_key_path(section, where):
    with pytest.raises(LoggerConfigError, match=where):
        logging_config_from_scene(section)


def test_api_key_in_both_spellings_gives_the_same_seq_sink():
    specs = []
    for key in ("api_key", "apiKey"):
        section = {"destination": {"type": "Seq", "endpoint": "http://127.0.0.1:9", key: "k"}}
        (spec,) = logging_config_from_scene(section).destinations
        specs.append(spec)
        (sink,) = logging_config_from_scene(section).create_sinks()
        try:
            assert isinstance(sink, SeqSink)
            assert sink.url == "http://127.0.0.1:9/ingest/clef"
        finally:
            sink.close()
    assert (
        specs[0]
        == specs[1]
        == SinkSpec("seq", (("endpoint", "http://127.0.0.1:9"), ("api_key", "k")))
    )
    both = {"destination": {"type": "Seq", "api_key": "a", "apiKey": "b"}}
    with pytest.raises(LoggerConfigError, match=r"give only one of 'api_key' and 'apiKey'"):
        logging_config_from_scene(both)


def test_key_path_prefix_for_scenario_files():
    with pytest.raises(LoggerConfigError, match=r"^scene\.json: logging\.enable"):
        logging_config_from_scene({"enable": 1}, path="scene.json: logging")
