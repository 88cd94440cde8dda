"""Figures of the simulator's records, drawn with matplotlib's Agg (no display): the plotting library that
`auv-mj plot`, `check-arena`, `arena`, the demo, the benchmark's failure files and the reproduction's sections use.

- `trajectory`: maps with the vehicle's tracks (Figs. 9-11, 13a, 14a, 16) and galleries of them;
- `tracking`: speed and heading against their commands, and the tracking errors (Figs. 12-14, 17);
- `trajectory3d`: a 6-DOF episode's depth against time and its track in 3-D;
- `curves`: learning curves from training logs (Fig. 8);
- `arenas`: previews of arenas from above (a tube also from the side), and how a preview is known;
- `canvas`: the figure, its size in pixels and its saving, shared by the others.

The figures sit in the simulator core above the arenas and the episode loop, whose records they draw.
"""
