"""Licences from Python: resolve_license / print_license_info with the original's rules on
built-in manifests written here and on user libraries, and the config key license_policy."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

import mlspaces
from mlspaces import Registry
from mlspaces.configs import PickBaseConfig, to_native
from mlspaces.utils import license_utils
from mlspaces.utils.license_utils import print_license_info, resolve_license

from conftest import EXAMPLE_DIR


def _annotated_library(root: Path) -> Path:
    """The tutorial library plus an Objaverse-like asset (isObjaverse, Sketchfab by-nc) and a
    user asset with license_info cc0."""
    lib = root / "lib"
    shutil.copytree(EXAMPLE_DIR / "asset_library", lib)
    index = json.loads((lib / "assets_index.json").read_text())
    metas = {
        "obj_nc": {"assetId": "obj_nc", "isObjaverse": True,
                   "license_info": {"license": "by-nc", "uri": "https://sketchfab.com/m/1",
                                    "creator_username": "dee", "creator_display_name": "Dee",
                                    "creator_profile_url": "https://sketchfab.com/dee"}},
        "cc0_block": {"assetId": "cc0_block", "license_info": {"license": "cc0"}},
    }
    for uid, meta in metas.items():
        (lib / uid).mkdir()
        (lib / uid / f"{uid}.xml").write_text("<mujoco/>")
        (lib / uid / f"{uid}.json").write_text(json.dumps(meta))
        index[uid] = {"uid": uid, "object_path": f"{uid}/{uid}.xml",
                      "metadata_path": f"{uid}/{uid}.json", "metadata_npz_path": None}
    (lib / "assets_index.json").write_text(json.dumps(index, indent=4))
    return lib


@pytest.fixture
def registry(tmp_path, monkeypatch) -> Registry:
    assets = tmp_path / "assets"
    (assets / "objects" / "thor").mkdir(parents=True)
    (assets / "objects" / "thor" / "mjthor_resource_file_to_size_mb.json").write_text(
        json.dumps({"thor_Apple_1.tar.zst": 1, "thor_Apple_12.tar.zst": 1}))
    monkeypatch.setenv("MLSPACES_CACHE_DIR", str(tmp_path / "cache"))
    reg = Registry(assets)
    reg.register_user_asset_library("custom_assets", _annotated_library(tmp_path))
    return reg


def test_resolve_license_follows_the_original_rules(registry):
    nc = resolve_license("objects", "objaverse", "obj_nc", registry=registry)
    assert list(nc)[:3] == ["data_type", "data_source", "asset_id"]
    assert nc["license"] == "CC-BY-NC-4.0" and nc["commercial_use"] is False
    assert nc["attribution"] == ("Model by Dee (dee), licensed under CC BY-NC 4.0. "
                                 "Non-commercial use only.")
    # Substring over the manifest's archive names; the first match wins.
    thor = resolve_license("objects", "thor", "Apple_1", registry=registry)
    assert thor["asset_id_or_archive_name"] == "Apple_1" and thor["license"] == "CC-BY-4.0"
    assert resolve_license("robots", "franka_droid", registry=registry)["license"] == "Apache 2.0"
    # User libraries: license_info when present, else "unknown" (the original raises).
    assert resolve_license("objects", "custom_assets", "cc0_block",
                           registry=registry)["license"] == "CC0-1.0"
    assert resolve_license("objects", "custom_assets", "red_block",
                           registry=registry)["license"] == "unknown"
    with pytest.raises(ValueError, match="is not in source='thor'"):
        resolve_license("objects", "thor", "Pear", registry=registry)
    with pytest.raises(mlspaces.MlspacesError, match="Can't determine license for `objects`"):
        resolve_license("objects", "elsewhere", "x", registry=registry)
    with pytest.raises(ValueError, match="Missing identifier"):
        resolve_license("objects", "thor", registry=registry)


def test_print_license_info_prints_json_or_identifiers(registry, capsys):
    print_license_info("objects", "custom_assets", "cc0_block", registry=registry)
    printed = capsys.readouterr().out
    assert printed.startswith('{\n  "data_type": "objects",')
    assert json.loads(printed)["license_url"].endswith("/zero/1.0/")
    print_license_info("objects", "thor", "--list_all", registry=registry)
    assert capsys.readouterr().out == "Possible identifiers: ['Apple_1', 'Apple_12']\n"
    print_license_info("objects", "thor", "Pear", registry=registry)
    out = capsys.readouterr().out
    assert "identifier='Pear' is not in source='thor'" in out
    assert out.endswith("Possible identifiers:\nApple_1\nApple_12\n")
    with pytest.raises(ValueError, match="--list_all"):
        print_license_info("objects", "thor")
    assert license_utils.object_license_key("obj_nc", registry=registry) == "by-nc"
    assert license_utils.NON_COMMERCIAL_LICENSES == {"by-nc", "by-nc-sa"}


def test_license_policy_config_key_and_environment(monkeypatch):
    assert PickBaseConfig().license_policy is None
    native = to_native(PickBaseConfig(license_policy="commercial_safe"), Registry())
    assert native["license_policy"] == "commercial_safe"
    text = mlspaces._core.resolve_config_yaml(json.dumps(native), "py", ".", False)
    assert "license_policy: commercial_safe" in text
    bad = to_native(PickBaseConfig(license_policy="research_only"), Registry())
    with pytest.raises(mlspaces.MlspacesError, match="license_policy"):
        mlspaces._core.resolve_config_yaml(json.dumps(bad), "py", ".", False)
    monkeypatch.setenv("MLSPACES_LICENSE_POLICY", "commercial_safe")
    assert license_utils.resolve_license_policy() == "commercial_safe"
    assert license_utils.resolve_license_policy("all") == "all"
    monkeypatch.setenv("MLSPACES_LICENSE_POLICY", "bogus")
    with pytest.raises(Exception, match="MLSPACES_LICENSE_POLICY"):
        license_utils.resolve_license_policy()
