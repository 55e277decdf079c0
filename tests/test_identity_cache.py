"""The identity-keyed cache of the models' design-independent tables
(:mod:`suspenv.core.identity_cache`): a hit needs the same objects, not equal ones."""

from suspenv.core.identity_cache import IdentityCache


class _Frozen:
    def __eq__(self, other: object) -> bool:  # equal to every other: identity decides
        return isinstance(other, _Frozen)

    __hash__ = object.__hash__


def test_a_hit_needs_the_same_objects_and_equal_values():
    cache: IdentityCache[int] = IdentityCache()
    a, b = _Frozen(), _Frozen()
    built: list[int] = []

    def build() -> int:
        built.append(len(built))
        return built[-1]

    assert cache.get([a], (1.0,), build) == 0
    assert cache.get([a], (1.0,), build) == 0  # the same object and value: kept
    assert cache.get([b], (1.0,), build) == 1  # an equal but other object: built
    assert cache.get([a], (2.0,), build) == 2  # another value: built
    assert len(built) == 3


def test_the_cache_is_cleared_whole_when_full():
    cache: IdentityCache[int] = IdentityCache(size=2)
    held = [_Frozen() for _ in range(3)]
    builds = [0]

    def build() -> int:
        builds[0] += 1
        return builds[0]

    for o in held[:2]:
        cache.get([o], (), build)
    assert cache.get([held[0]], (), build) == 1 and builds[0] == 2  # both kept
    cache.get([held[2]], (), build)  # full: cleared, then the third kept
    assert cache.get([held[2]], (), build) == 3
    assert cache.get([held[0]], (), build) == 4  # the first was dropped: built again
