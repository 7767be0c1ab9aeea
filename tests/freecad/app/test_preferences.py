"""Workbench preferences read back within their documented ranges."""

from fairing_wb import preferences


def test_sample_density_preference_is_capped():
    """A density saved outside the dialog's range (by a macro, an old config) is clamped."""
    params = preferences.params()
    saved = params.GetInt("SampleDensity", 60)
    try:
        params.SetInt("SampleDensity", 100000)
        assert preferences.sample_density() == preferences.DENSITY_RANGE[1] == 400
        params.SetInt("SampleDensity", 2)
        assert preferences.sample_density() == 8
    finally:
        params.SetInt("SampleDensity", saved)
