"""Studies on the IRS: the paper's figures (Figure 10 and Figures 5-10), design sweeps on Dask,
similitude, and the torque-car study.
"""
