"""Actor files: written from a training checkpoint, loaded back, and every bad file
rejected with one line naming it and what does not match."""

from __future__ import annotations

import dataclasses

import pytest
import torch

from explore_rl.config import load_config
from explore_rl.models.actor_file import (
    ACTOR_FORMAT,
    ActorFile,
    load_actor,
    read_actor_file,
    save_actor_file,
)
from explore_rl.models.config import ModelConfig
from explore_rl.models.checkpoint import CheckpointError
from tests.policy_files import TINY_MODEL, actor_file, training_checkpoint


def one_line(error: pytest.ExceptionInfo) -> str:
    message = str(error.value)
    assert "\n" not in message
    return message


def test_an_actor_file_holds_the_trained_actor_and_its_model(tmp_path):
    path, learner = actor_file(tmp_path)
    actor, contents = load_actor(path)
    assert torch.load(path, weights_only=True)["format"] == ACTOR_FORMAT
    assert contents.model.hidden == 16 and contents.features == ["uncertainty", "distance", "bearing", "identity"]
    trained = learner.actor.module[0].module  # ProbabilisticActor -> TensorDictModule -> GraphActor
    for key, value in trained.state_dict().items():
        assert torch.equal(actor.state_dict()[key], value), key
    assert not actor.training
    # smaller than the training checkpoint (no critic, no optimiser)
    assert path.stat().st_size < 0.5 * (tmp_path / "training.pt").stat().st_size


def test_a_training_checkpoint_loads_as_an_actor_too(tmp_path):
    checkpoint, learner = training_checkpoint(tmp_path / "best.pt")
    actor, contents = load_actor(checkpoint)
    assert contents.meta["kind"] == "training checkpoint"
    x, adj = torch.rand(1, 6, 4), torch.diag(torch.ones(5), 1)[None]
    mask = torch.ones(1, 6, dtype=torch.bool)
    expected = learner.actor.module[0].module.eval()(x, adj + adj.transpose(1, 2), mask)
    assert torch.allclose(actor(x, adj + adj.transpose(1, 2), mask), expected)


def test_paper_size_actor_file_is_under_32_mb(tmp_path):
    model = ModelConfig(hidden=1000, mlp_hidden=0)
    from explore_rl.models.actor_critic import GraphActor

    weights = GraphActor(model, 4).state_dict()
    path = save_actor_file(tmp_path / "paper.pt", ActorFile(model, weights))
    assert path.stat().st_size < 32 * 2**20
    load_actor(path, expected_model=model)


def test_a_missing_file_names_it_and_how_to_get_one(tmp_path):
    with pytest.raises(CheckpointError) as error:
        load_actor(tmp_path / "nowhere" / "actor.pt")
    message = one_line(error)
    assert "nowhere/actor.pt: no checkpoint there" in message and "explore-rl-train" in message
    assert "explore-rl-export" in message


def test_a_corrupt_file_is_rejected(tmp_path):
    path = tmp_path / "actor.pt"
    path.write_bytes(b"not a torch file at all")
    with pytest.raises(CheckpointError, match=r"actor\.pt: not a readable checkpoint") as error:
        load_actor(path)
    one_line(error)
    assert "weights_only" not in str(error.value) and "explore-rl-export" in str(error.value)
    torch.save({"format": "something/else"}, path)
    with pytest.raises(CheckpointError, match=r"actor\.pt: not an explore_rl checkpoint \(format 'something/else'"):
        load_actor(path)


def test_a_different_hidden_size_than_expected_is_named(tmp_path):
    path, _ = actor_file(tmp_path)
    expected = dataclasses.replace(load_config(TINY_MODEL).model, hidden=32)
    with pytest.raises(CheckpointError, match=r"actor\.pt: model\.hidden is 16 in the checkpoint but 32") as error:
        load_actor(path, expected_model=expected)
    one_line(error)


def test_weights_of_another_size_than_the_file_declares_are_named(tmp_path):
    path, _ = actor_file(tmp_path)
    contents = read_actor_file(path)
    save_actor_file(path, dataclasses.replace(contents, model=dataclasses.replace(contents.model, hidden=24)))
    with pytest.raises(CheckpointError, match=r"actor\.pt: actor weight .* has shape .* expects") as error:
        load_actor(path)
    one_line(error)


def test_a_different_feature_count_is_named(tmp_path):
    path, _ = actor_file(tmp_path)
    contents = read_actor_file(path)
    five = dataclasses.replace(contents, features=contents.features + ["extra"],
                               model=dataclasses.replace(contents.model, feature_scale=[1.0] * 5))
    save_actor_file(path, five)
    with pytest.raises(CheckpointError, match=r"actor\.pt: node features .*'extra'.* are no feature set") as error:
        load_actor(path)
    one_line(error)
    # a first layer for 5 features under the 4 feature names: the weight shapes say so
    weights = dict(contents.weights)
    key = "unet.down_convs.0.lin.weight"
    weights[key] = torch.zeros(weights[key].shape[0], 5)
    save_actor_file(path, dataclasses.replace(contents, weights=weights))
    with pytest.raises(CheckpointError, match=r"a different feature count"):
        load_actor(path)


# ---------------------------------------------------------------- issue 20 item 5


@pytest.mark.parametrize("bad", [float("nan"), float("inf")])
def test_non_finite_weights_are_rejected_in_one_line(tmp_path, bad):
    path, _ = actor_file(tmp_path)
    contents = read_actor_file(path)
    weights = dict(contents.weights)
    key = "unet.down_convs.0.lin.weight"
    weights[key] = weights[key].clone()
    weights[key][0, 0] = bad
    save_actor_file(path, dataclasses.replace(contents, weights=weights))
    with pytest.raises(CheckpointError, match=r"actor\.pt: actor weight 'unet\.down_convs\.0\.lin\.weight' "
                                              r"holds NaN or inf \(1 of \d+ tensors") as error:
        load_actor(path)
    one_line(error)


def test_export_to_a_folder_fails_in_one_line_and_leaves_no_temporary_file(tmp_path, capsys):
    from explore_rl.deploy import main

    path, _ = actor_file(tmp_path)
    target = tmp_path / "policies"
    target.mkdir()
    before = sorted(p.name for p in tmp_path.rglob("*"))
    with pytest.raises(SystemExit) as exit_info:
        main([str(path), str(target)])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err.strip()
    assert err == f"error: {target} is a folder: give the file to write, e.g. {target / 'actor.pt'}"
    with pytest.raises(SystemExit):
        main([str(path), str(tmp_path / "out.pt"), "--program", str(target)])
    assert "is a folder" in capsys.readouterr().err and not (tmp_path / "out.pt").exists()
    assert sorted(p.name for p in tmp_path.rglob("*")) == before  # no stray .tmp


def test_a_failed_write_removes_its_temporary_file(tmp_path, monkeypatch):
    path, _ = actor_file(tmp_path)
    contents = read_actor_file(path)
    out = tmp_path / "new" / "actor.pt"

    def broken_replace(source, target):
        raise OSError("disk full")

    monkeypatch.setattr("explore_rl.models.actor_file.os.replace", broken_replace)
    with pytest.raises(OSError, match="disk full"):
        save_actor_file(out, contents)
    assert list(out.parent.iterdir()) == []


def test_an_actor_blind_to_the_covariance_columns_converts_exactly(tmp_path, capsys):
    """``with_features`` / ``explore-rl-export --features``: an extended actor whose input weights on the three
    covariance columns are 0 becomes a ``no_covariance`` actor that gives the same logits on the other seven
    columns; an actor that reads them is refused in one line (it would decide differently)."""
    from explore_rl.deploy import main
    from explore_rl.graph.features import feature_names
    from explore_rl.models.actor_critic import INPUT_WEIGHT

    path, _ = actor_file(tmp_path / "extended", load_config(["graph.features=extended", *TINY_MODEL]))
    extended = read_actor_file(path)
    blind_columns = [extended.features.index(name) for name in ("uncertainty", "revisit_uncertainty",
                                                                  "landmark_uncertainty")]
    weight = extended.weights[INPUT_WEIGHT].clone()
    weight[:, blind_columns] = 0
    blind = dataclasses.replace(extended, weights={**extended.weights, INPUT_WEIGHT: weight})
    save_actor_file(tmp_path / "blind.pt", blind)
    main([str(tmp_path / "blind.pt"), str(tmp_path / "no_cov.pt"), "--features", "no_covariance"])
    wide, _ = load_actor(tmp_path / "blind.pt")
    narrow, converted = load_actor(tmp_path / "no_cov.pt")
    assert converted.feature_set == "no_covariance" and converted.meta["converted_from_features"] == "extended"
    kept = [extended.features.index(name) for name in feature_names("no_covariance")]
    torch.manual_seed(0)
    x = torch.randn(2, 9, 10) * 3
    adj = (torch.rand(2, 9, 9) > 0.6).float()
    adj = torch.triu(adj, 1) + torch.triu(adj, 1).transpose(1, 2)
    mask = torch.ones(2, 9, dtype=torch.bool)
    with torch.no_grad():
        torch.testing.assert_close(narrow(x[..., kept], adj, mask), wide(x, adj, mask), rtol=1e-5, atol=1e-6)
    capsys.readouterr()
    with pytest.raises(SystemExit):
        main([str(path), str(tmp_path / "refused.pt"), "--features", "no_covariance"])
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "--features no_covariance" in err and "would decide differently" in err
    assert not (tmp_path / "refused.pt").exists()
