"""The test scheduler's groups (tests/support/scheduling.py): tests that share a module-wide
fixture, directly or through another fixture, run together; the others spread alone."""

from tests.support.scheduling import group_of, grouped_tests

SOURCE = '''
import pytest

@pytest.fixture(scope="module")
def render(tmp_path_factory): ...

@pytest.fixture
def views(render): ...

@pytest.fixture
def alone(tmp_path): ...

def test_direct(render): ...
def test_through(views, tmp_path): ...
def test_free(alone): ...
'''


def test_users_of_a_shared_fixture_are_grouped_and_no_other():
    assert grouped_tests(SOURCE) == {"test_direct", "test_through"}
    groups = {"tests/t.py": grouped_tests(SOURCE)}
    assert group_of("tests/t.py::test_through[a-1]", groups) == "tests/t.py"
    assert group_of("tests/t.py::test_free", groups) == "tests/t.py::test_free"
    assert group_of("tests/u.py::test_direct", groups) == "tests/u.py::test_direct"


def test_a_shared_autouse_fixture_groups_the_whole_module():
    source = SOURCE.replace('scope="module"', 'scope="module", autouse=True')
    assert grouped_tests(source) is None
    assert group_of("tests/t.py::test_free", {"tests/t.py": None}) == "tests/t.py"


def test_function_fixtures_alone_group_nothing():
    assert grouped_tests(SOURCE.replace('scope="module"', 'scope="function"')) == set()
