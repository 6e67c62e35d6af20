"""The receiving side of `live/tests/lsl.rs`: starts the bridge
(`python -m skinread.lsl`), opens an inlet on its outlets, pushes a
stimulus marker of its own when told (`go` on stdin), and prints what
it received as JSON."""

import json
import subprocess
import sys
import time

import pylsl
import pylsl.util

url, name = sys.argv[1], sys.argv[2]
bridge = subprocess.Popen([sys.executable, "-m", "skinread.lsl", url, "--name", name,
                           "--markers-from", name + "-stim", "--linger", "3"])
stim = pylsl.StreamOutlet(pylsl.StreamInfo(name + "-stim", "Markers", 1, pylsl.IRREGULAR_RATE,
                                           pylsl.cf_string, name + "-stim"))
found = pylsl.resolve_byprop("name", name, timeout=30)
mfound = pylsl.resolve_byprop("name", name + " markers", timeout=30)
assert found and mfound, "the bridge's outlets were not found"
inlet = pylsl.StreamInlet(found[0], max_buflen=60, recover=False)
minlet = pylsl.StreamInlet(mfound[0], max_buflen=60, recover=False)
info = inlet.info(timeout=10)
inlet.open_stream(timeout=10)
minlet.open_stream(timeout=10)
print("ready", flush=True)
assert sys.stdin.readline().strip() == "go"
# The bridge's own inlet on this stream may take a second to connect.
time.sleep(1.5)
stim.push_sample(["stimulus on"])
utc_minus_lsl = time.time() - pylsl.local_clock()

samples, stamps, markers = [], [], []
quiet = time.time()
while time.time() - quiet < 4:
    try:
        chunk, ts = inlet.pull_chunk(timeout=0.2)
        mchunk, mts = minlet.pull_chunk(timeout=0.0)
    except pylsl.util.LostError:
        break  # the bridge closed its outlets: the feed has ended
    if chunk or mchunk:
        quiet = time.time()
    samples += chunk
    stamps += ts
    markers += [(m[0], t + utc_minus_lsl) for m, t in zip(mchunk, mts)]
bridge.wait(timeout=30)

desc = info.desc()
labels, ch = [], desc.child("channels").child("channel")
while not ch.empty():
    labels.append((ch.child_value("label"), ch.child_value("unit")))
    ch = ch.next_sibling()
flags, fl = [], desc.child("flags").child("flag")
while not fl.empty():
    flags.append((fl.child_value("name"), fl.child_value("fault")))
    fl = fl.next_sibling()
print(json.dumps({
    "type": info.type(),
    "channels": info.channel_count(),
    "labels": labels,
    "flags": flags,
    "samples": [[None if x != x else x for x in s] for s in samples],
    "utc": [t + utc_minus_lsl for t in stamps],
    "markers": markers,
    "bridge": bridge.returncode,
}), flush=True)
