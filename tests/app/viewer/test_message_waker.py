"""The wakers of the viewer's sleeping loop: a worker's message, a signal."""

import multiprocessing
import os
import signal
import threading

from app.viewer.message_waker import MessageWaker, SignalWaker


def test_a_message_wakes_the_loop_once_until_it_is_read():
    reader, writer = multiprocessing.Pipe(duplex=False)
    woken = threading.Semaphore(0)
    waker = MessageWaker(reader, woken.release, "test-waker", patience=5.0)
    try:
        writer.send("progress")
        assert woken.acquire(timeout=5)
        assert not woken.acquire(timeout=0.3)  # unread: no second wake within `patience`
        reader.recv()
        waker.read()
        writer.send("done")
        assert woken.acquire(timeout=5)
    finally:
        waker.close()
        writer.close()
        reader.close()


def test_a_signal_wakes_the_loop_at_once_and_the_descriptor_comes_back():
    # The loop sleeps in a C call (glfw.wait_events_timeout) in which Python cannot run the
    # handler: the waker's thread must be called before that sleep would end by itself.
    woken, handled = threading.Event(), []
    previous = signal.signal(signal.SIGUSR1, lambda *_: handled.append(True))
    before = signal.set_wakeup_fd(-1)
    signal.set_wakeup_fd(before)
    try:
        with SignalWaker(woken.set):
            os.kill(os.getpid(), signal.SIGUSR1)
            assert woken.wait(timeout=5)
        assert handled == [True]
        assert signal.set_wakeup_fd(before) == before  # the previous descriptor is back
    finally:
        signal.signal(signal.SIGUSR1, previous)
    assert not any(thread.name == "signal-waker" for thread in threading.enumerate())
