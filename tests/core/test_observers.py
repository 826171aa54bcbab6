"""WeakObserver: a traits observer that does not keep its owner alive (core.observers)."""

import gc
import weakref

import pytest

from grasswidget.core.observers import WeakObserver
from grasswidget.core.params import GrassParams
from grasswidget.errors import GrassTypeError


class Follower:
    def __init__(self, params, names):
        self.seen = []
        self.observer = WeakObserver(params, self.on_change, names=names)

    def on_change(self, change):
        self.seen.append((change["name"], change["new"]))


def test_calls_the_method_for_its_names_until_stopped():
    params = GrassParams()
    follower = Follower(params, ["wind_strength"])
    params.wind_strength = 3.0
    params.gravity = 5.0  # not observed
    assert follower.seen == [("wind_strength", 3.0)]
    follower.observer.stop()
    follower.observer.stop()  # idempotent
    params.wind_strength = 4.0
    assert follower.seen == [("wind_strength", 3.0)] and not follower.observer.active


def test_does_not_keep_its_owner_and_goes_at_the_next_change():
    from traitlets import All

    params = GrassParams()
    follower = Follower(params, All)
    params.gravity = 4.0
    assert follower.seen == [("gravity", 4.0)]
    owner, observer = weakref.ref(follower), follower.observer
    del follower
    gc.collect()
    assert owner() is None  # the params did not keep it
    assert observer.active  # nothing changed yet
    params.wind_strength = 2.5  # the observer finds its owner gone and removes itself
    assert not observer.active
    held = weakref.ref(observer)
    del observer
    gc.collect()
    assert held() is None  # and the params no longer hold it


def test_refuses_what_is_not_a_bound_method():
    with pytest.raises(GrassTypeError, match="method must be a bound method"):
        WeakObserver(GrassParams(), lambda change: None)
