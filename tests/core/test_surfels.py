"""Input validation of illumap.Surfels (and of the operator/solver parameters)."""

import numpy as np
import pytest

import illumap
from illumap import InputError, Surfels


def arrays(n=5, seed=0):
    rng = np.random.default_rng(seed)
    normals = rng.normal(size=(n, 3))
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    return dict(positions=rng.normal(size=(n, 3)), normals=normals,
                areas=rng.uniform(0.1, 1.0, n), albedo=rng.uniform(0.0, 0.9, (n, 3)),
                emission=rng.uniform(0.0, 2.0, (n, 3)))


def make(**changes):
    data = arrays()
    data.update(changes)
    return Surfels(**data)


def test_valid_input_is_copied_float64_readonly():
    data = arrays()
    s = Surfels(**data)
    assert s.n == len(s) == 5
    for name in ("positions", "normals", "areas", "albedo", "emission"):
        a = getattr(s, name)
        assert a.dtype == np.float64 and a.flags.c_contiguous and not a.flags.writeable
        assert a is not data[name]
        np.testing.assert_allclose(a, data[name], rtol=1e-15)
    data["positions"][0, 0] = 123.0          # the caller's array stays theirs
    assert s.positions[0, 0] != 123.0
    with pytest.raises(AttributeError):
        s.positions = data["positions"]


def test_float32_and_lists_accepted():
    data = {k: v.astype(np.float32) for k, v in arrays().items()}
    s = Surfels(**data)
    assert s.positions.dtype == np.float64
    np.testing.assert_allclose(np.linalg.norm(s.normals, axis=1), 1.0, rtol=1e-12)
    s2 = Surfels(**{k: v.tolist() for k, v in arrays().items()})
    assert s2.n == 5
    # Fortran-ordered input comes out C-contiguous
    s3 = make(positions=np.asfortranarray(arrays()["positions"]))
    assert s3.positions.flags.c_contiguous


@pytest.mark.parametrize("name, bad, expected", [
    ("positions", np.zeros((5, 2)), r"positions: expected shape \(N, 3\)"),
    ("normals", np.zeros((4, 3)), r"normals: expected shape \(N, 3\) = \(5, 3\), got \(4, 3\)"),
    ("areas", np.ones((5, 1)), r"areas: expected shape \(N,\) = \(5,\), got \(5, 1\)"),
    ("albedo", np.zeros(5), r"albedo: expected shape \(N, 3\) = \(5, 3\), got \(5,\)"),
    ("emission", np.zeros((5, 4)), r"emission: expected shape \(N, 3\)"),
])
def test_shape_errors_name_the_array_and_shape(name, bad, expected):
    with pytest.raises(InputError, match=expected):
        make(**{name: bad})


@pytest.mark.parametrize("name", ["positions", "normals", "areas", "albedo", "emission"])
@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
def test_non_finite_named_with_index(name, value):
    data = arrays()
    array = data[name].copy()
    k = 3
    if array.ndim == 2:
        array[k, 1] = value
        where = rf"{name}\[3, 1\]"
    else:
        array[k] = value
        where = rf"{name}\[3\]"
    data[name] = array
    with pytest.raises(InputError, match=where + r" = .* is not finite") as info:
        Surfels(**data)
    assert repr(float(value)) in str(info.value)


def test_first_bad_index_is_reported():
    data = arrays(n=10)
    data["positions"][7, 0] = np.nan
    data["positions"][4, 2] = np.nan
    with pytest.raises(InputError, match=r"positions\[4, 2\]"):
        Surfels(**data)


def test_zero_normal():
    normals = arrays()["normals"]
    normals[2] = 0.0
    with pytest.raises(InputError, match=r"normals\[2\].*zero length"):
        make(normals=normals)


def test_non_unit_normal_raises_with_index_and_length():
    normals = arrays()["normals"]
    normals[4] *= 1.01
    with pytest.raises(InputError, match=r"normals\[4\].*length 1\.01.*unit length"):
        make(normals=normals)
    normals = arrays()["normals"]
    normals[1] *= 0.5
    with pytest.raises(InputError, match=r"normals\[1\]"):
        make(normals=normals)


def test_nearly_unit_normals_are_normalized():
    data = arrays()
    normals = data["normals"].copy()
    normals[0] *= 1.0 + 5e-4
    normals[1] *= 1.0 - 5e-4
    s = make(normals=normals)
    np.testing.assert_allclose(np.linalg.norm(s.normals, axis=1), 1.0, rtol=0, atol=1e-15)
    np.testing.assert_allclose(s.normals[0], data["normals"][0], rtol=1e-12)


@pytest.mark.parametrize("value", [0.0, -1.0])
def test_area_must_be_positive(value):
    areas = arrays()["areas"]
    areas[3] = value
    with pytest.raises(InputError, match=r"areas\[3\] = .* must be > 0"):
        make(areas=areas)


@pytest.mark.parametrize("value", [1.0, 1.5])
def test_albedo_of_one_or_more_raises(value):
    albedo = arrays()["albedo"]
    albedo[2, 0] = value
    with pytest.raises(InputError, match=r"albedo\[2, 0\] = .* must be < 1 .*diverge"):
        make(albedo=albedo)


def test_albedo_negative_raises_and_bounds_accepted():
    albedo = arrays()["albedo"]
    albedo[1, 2] = -0.1
    with pytest.raises(InputError, match=r"albedo\[1, 2\] = .* must be >= 0"):
        make(albedo=albedo)
    albedo = arrays()["albedo"]
    albedo[0] = 0.0
    albedo[1] = np.nextafter(1.0, 0.0)
    assert make(albedo=albedo).n == 5


def test_negative_emission_raises():
    emission = arrays()["emission"]
    emission[4, 1] = -1e-9
    with pytest.raises(InputError, match=r"emission\[4, 1\] = .* must be >= 0"):
        make(emission=emission)


def test_empty_raises():
    with pytest.raises(InputError, match=r"N = 0"):
        Surfels(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0), np.zeros((0, 3)),
                np.zeros((0, 3)))


def test_non_numeric_and_none_raise_input_error():
    with pytest.raises(InputError, match="positions"):
        make(positions=[["a", "b", "c"]] * 5)
    with pytest.raises(InputError, match="areas: missing"):
        make(areas=None)
    with pytest.raises(InputError, match="normals"):
        make(normals=np.ones((5, 3), dtype=complex))
    with pytest.raises(InputError, match="emission"):
        make(emission=[[1, 2, 3], [1, 2]] + [[0, 0, 0]] * 3)


def test_input_error_is_value_error():
    assert issubclass(InputError, ValueError)
    assert issubclass(illumap.Cancelled, Exception)


def test_absurd_size_refused_with_estimate(monkeypatch):
    from illumap import surfels as module
    monkeypatch.setattr(module, "_physical_memory_bytes", lambda: 1_000)
    with pytest.raises(InputError, match=r"N = 5 surfels would need about .* GiB"):
        make()


def test_pickle_and_copy_round_trip():
    import copy
    import pickle
    s = make()
    for t in (pickle.loads(pickle.dumps(s)), copy.deepcopy(s), copy.copy(s)):
        assert isinstance(t, Surfels) and t.same_geometry(s)
        np.testing.assert_array_equal(t.emission, s.emission)


def test_replace_revalidates():
    s = make()
    t = s.replace(albedo=np.full((5, 3), 0.25))
    assert np.all(t.albedo == 0.25) and t.same_geometry(s)
    with pytest.raises(InputError, match="albedo"):
        s.replace(albedo=np.full((5, 3), 1.0))
    moved = s.replace(positions=s.positions + 1.0)
    assert not moved.same_geometry(s)


@pytest.mark.parametrize("keywords, expected", [
    (dict(method="bogus"), "method"),
    (dict(near_field="sphere"), "near_field"),
    (dict(order=-1), "order"),
    (dict(order=2.5), "order"),
    (dict(theta=0.0), "theta"),
    (dict(theta=1.5), "theta"),
    (dict(leaf_size=0), "leaf_size"),
    (dict(visibility="bogus"), "visibility"),
    (dict(visibility="exact", coverage=0.0), "coverage"),
    (dict(visibility="seed", seed_t1=1.5), "seed_t1"),
    (dict(visibility="exact", visibility_leaf_mode="bogus"), "visibility_leaf_mode"),
])
def test_operator_parameters_validated_before_native(keywords, expected):
    with pytest.raises(InputError, match=expected):
        illumap.TransportOperator(make(), **keywords)


def test_operator_needs_surfels():
    with pytest.raises(InputError, match="illumap.Surfels"):
        illumap.TransportOperator(arrays())


@pytest.mark.parametrize("keywords, expected", [
    (dict(solver="lu"), "solver"),
    (dict(tol=0.0), "tol"),
    (dict(tol=2.0), "tol"),
    (dict(max_iterations=0), "max_iterations"),
    (dict(progress=3), "progress"),
    (dict(visibility="seed", seed_k=0), "seed_k"),
])
def test_solve_parameters_validated(keywords, expected):
    with pytest.raises(InputError, match=expected):
        illumap.solve(make(), **keywords)
    dark = make(emission=np.zeros((5, 3)))      # E = 0 short-cut still validates everything
    with pytest.raises(InputError, match=expected):
        illumap.solve(dark, **keywords)


def test_solve_rejects_unknown_keyword():
    with pytest.raises(TypeError, match="unexpected keyword"):
        illumap.solve(make(), colour="red")
