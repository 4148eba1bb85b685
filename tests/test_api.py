"""The public surface: everything in chronofuse.api.__all__ exists and is what its module defines."""

import chronofuse.api as api


def test_every_public_name_is_importable_from_the_api():
    missing = [name for name in api.__all__ if not hasattr(api, name)]
    assert not missing


def test_the_api_reexports_rather_than_redefines():
    for name in api.__all__:
        obj = getattr(api, name)
        module = getattr(obj, "__module__", None)
        if module is not None:
            assert module.startswith("chronofuse.") and module != "chronofuse.api", name
