"""The package as a MolmoSpaces user meets it: mirrored module paths, the process-default
registry behind the module functions, one MuJoCo shared with `import mujoco`."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import write_library


def test_mirrored_module_paths_and_process_default_registry(tmp_path, tutorial_library):
    from mlspaces.molmo_spaces_constants import (OBJECT_LIBRARY_TO_GRASP_LIBRARIES,
                                                 USER_ASSET_LIBRARIES, USER_GRASP_LIBRARIES,
                                                 register_user_asset_library,
                                                 register_user_grasp_library)
    from mlspaces.utils.grasps import (get_pickup_grasp_path, has_valid_pickup_grasps,
                                       load_pickup_grasps)
    from mlspaces.utils.lazy_loading_utils import install_uid, locate_uid_package
    from mlspaces.utils.object_metadata import ObjectMeta

    register_user_asset_library("custom_assets_pkg", tutorial_library)
    register_user_grasp_library("custom_grasps_pkg", tutorial_library, "custom_assets_pkg")
    assert USER_ASSET_LIBRARIES["custom_assets_pkg"] == tutorial_library.absolute()
    assert "custom_grasps_pkg/droid" in USER_GRASP_LIBRARIES
    assert OBJECT_LIBRARY_TO_GRASP_LIBRARIES["custom_assets_pkg"] == ["custom_grasps_pkg/droid"]
    with pytest.raises(ValueError):
        register_user_asset_library("custom_assets_pkg", tutorial_library)

    source, package, xml = locate_uid_package("red_block")
    # The first library registered in this process that holds red_block answers (another test
    # file of the same pytest run may have registered the tutorial library before this one).
    first = next(n for n, p in USER_ASSET_LIBRARIES.items() if p == tutorial_library.absolute())
    assert source == first and package is None
    assert xml == (tutorial_library / "red_block" / "red_block.xml").absolute()
    assert install_uid("red_block") == xml
    with pytest.raises(ValueError, match="not found"):
        install_uid("not_a_uid")
    assert has_valid_pickup_grasps("red_block")
    assert get_pickup_grasp_path("red_block").name == "grasps.npz"
    assert load_pickup_grasps("red_block").shape == (1, 4, 4)

    assert ObjectMeta.annotation("red_block")["mass"] > 0
    assert ObjectMeta.annotation(["red_block", "nope"])[1] is None
    assert "red_block" in ObjectMeta.annotation()
    assert ObjectMeta.short_descriptions("nope") == []
    assert ObjectMeta.get_short_description("mug_3") == ["mug"] * 4

    lib = write_library(tmp_path / "feat", {"f1": 1, "f2": 1}, npz_meta=True)
    register_user_asset_library("feat_pkg", lib)
    feats = ObjectMeta.img_features(["f1", "f2"])
    assert feats.shape == (2, 3, 4) and feats.dtype == np.float32
    assert ObjectMeta.img_features("f1").shape == (1, 3, 4)
    with pytest.raises(KeyError):
        ObjectMeta.description_text_features("f1")
    assert ObjectMeta.short_descriptions(["f1"]) == [["block", "f1 block", "small f1 block"]]


def test_one_mujoco_in_the_process():
    """The extension runs on the libmujoco of the `mujoco` package, whichever is imported
    first: one file mapped."""
    code = (
        "import sys\n"
        "first = sys.argv[1]\n"
        "if first == 'mlspaces':\n"
        "    import mlspaces, mujoco\n"
        "else:\n"
        "    import mujoco, mlspaces\n"
        "maps = {l.split()[-1] for l in open('/proc/self/maps') if 'libmujoco' in l}\n"
        "assert len(maps) == 1, maps\n"
        "assert mlspaces._core.mujoco_runtime_version() == mujoco.__version__\n"
        "print(maps.pop())\n")
    paths = set()
    for first in ("mlspaces", "mujoco"):
        out = subprocess.run([sys.executable, "-c", code, first], check=True,
                             capture_output=True, text=True)
        paths.add(Path(out.stdout.strip()).resolve())
    import mujoco
    assert paths == {next(Path(mujoco.__file__).parent.glob("libmujoco.so*")).resolve()}
