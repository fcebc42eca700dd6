# The figure of docs/experiments/2026-12-06-warp-choice.md: root paths and
# lowest foot heights of held-out gaps 10 and 26 of set 1, from the fills
# that `scripts/energy-realism --sets 1 --ours --keep DIR` writes (DIR
# /tmp/er_keep: before the warp-and-work choice; /tmp/er_new: after).
# Run from the repository root with /usr/bin/python3 (numpy, matplotlib).
import sys
sys.path.insert(0, 'build/python')
import mocap, numpy as np
import matplotlib; matplotlib.use('Agg'); import matplotlib.pyplot as plt
fig, axes = plt.subplots(2, 2, figsize=(11, 7))
for row, gap in enumerate([10, 26]):
    for name, path, col in [('capture', f'/tmp/er_new/set1-{gap:04d}-capture.bvh', 'k'),
                            ('ours, warp alone (before)', f'/tmp/er_keep/set1-{gap:04d}-ours-(default:-W-warp).bvh', 'tab:blue'),
                            ('ours, warp + work (now)', f'/tmp/er_new/set1-{gap:04d}-ours-(default:-W-warp).bvh', 'tab:red')]:
        b = mocap.read_bvh(path); m = b.motion(); P = m['joint_positions_m']; n = list(b.joint_names)
        h = n.index('Hips'); feet = [n.index(x) for x in ['Foot_L', 'Toes_L', 'Foot_R', 'Toes_R']]
        ax = axes[row][0]
        ax.plot(P[:, h, 0], P[:, h, 2], color=col, label=name)
        for f, ls in zip(feet[::2], ['-', '--']):
            ax.plot(P[:, f, 0], P[:, f, 2], color=col, ls=ls, lw=0.7, alpha=0.6)
        ax.set_aspect('equal'); ax.set_title(f'gap {gap}: root and ankles from above (m)')
        ax2 = axes[row][1]
        ax2.plot(P[:, feet, 1].min(axis=1), color=col, label=name)
        ax2.axhline(0.10, color='grey', lw=0.5); ax2.set_title(f'gap {gap}: lowest foot joint height (m); contact below 0.10')
    axes[row][0].legend(fontsize=7); axes[row][1].legend(fontsize=7)
plt.tight_layout(); plt.savefig('docs/experiments/2026-12-06-warp-choice-feet.png', dpi=80)
