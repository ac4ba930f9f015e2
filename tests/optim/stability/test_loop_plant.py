"""margins.loop_plant: the identity fast path in front of the LRU cache gives what the cache gives."""

from models.device import Device
from models.plants import stiffness_loop_plant
from optim.stability.margins import loop_plant


def _same(p, q) -> bool:
    return repr(p) == repr(q) or p is q


def test_the_same_object_equal_objects_and_a_different_device_each_get_their_own_plant():
    a = Device(preset="lhifam", delay=0.002)
    a_again = Device(preset="lhifam", delay=0.002)          # equal, not identical
    b = Device(preset="lhifam", delay=0.003)
    pa = loop_plant(a)
    assert loop_plant(a) is pa                               # identity
    assert loop_plant(a_again) is pa                         # the LRU cache by equality
    pb = loop_plant(b)
    assert pb is not pa and _same(pb, stiffness_loop_plant(b))
    assert loop_plant(a) is pa                               # back to a after b
    rigid = a.rigid()
    assert _same(loop_plant(rigid), stiffness_loop_plant(rigid))
