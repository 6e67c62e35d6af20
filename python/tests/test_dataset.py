"""The data set readers on the repository's example data set and on a
written session's files."""

import os

import pandas as pd

import skinread

ROOT = os.path.join(os.path.dirname(__file__), "..", "..")


def test_the_example_data_set_reads_as_one_frame():
    df = skinread.read_dataset(os.path.join(ROOT, "data", "example"))
    traces = skinread.read_traces(os.path.join(ROOT, "data", "example"))
    assert len(traces) == 6
    assert len(df) == sum(len(t) for t in traces.values())
    assert set(df["file"]) == set(traces)
    assert df["cs_pf"].gt(0).all()


def test_flags_are_decoded_by_name_and_do_not_shadow_pandas(tmp_path):
    p = tmp_path / "records.csv"
    p.write_text(
        "segment,seq,t_us,sensor,f1_hz,z1_re_ohm,z1_im_ohm,f2_hz,z2_re_ohm,z2_im_ohm,c_pf,r_ohm,stretch_mm,chosen_hz,chi2,sigma_ln_c,flags\n"
        "1,1,500,0,1000,1,-1,4000,1,-1,205.0,7e5,0,4000,1,0.001,0\n"
        "1,2,500,1,1000,1,-1,4000,1,-1,,,,4000,1,,384\n"
        "1,3,1500,0,1000,1,-1,4000,1,-1,205.0,7e5,0,4000,1,0.001,4608\n"
    )
    df = skinread.read_records(str(tmp_path))
    assert "flags" not in df.columns and isinstance(df.flags, pd.Flags)
    assert list(df["flag_bits"]) == [0, 384, 4608]
    assert list(df["valid"]) == [True, False, True]
    assert list(df["MODEL"]) == [False, True, False]
    assert list(df["UNCERTAIN"]) == [False, True, False]
    assert list(df["TONE_LEFT_OUT"]) == [False, False, True]
    assert skinread.names(4608) == ["UNCALIBRATED", "TONE_LEFT_OUT"]
    per = skinread.by_sensor(df)
    assert sorted(per) == [0, 1] and list(per[0]["t_us"]) == [500, 1500]
