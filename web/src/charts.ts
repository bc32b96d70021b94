// Live charts of the run's timeline (/api/timeline, committed with each checkpoint), drawn with
// uPlot: Gaussians (total, resident, on disk), memory (host RSS, VRAM), chunk I/O (cumulative loads
// and saves) and optimisation steps per second. Redrawn when a checkpoint event arrives.
import uPlot from "uplot";
import "uplot/dist/uPlot.min.css";

export interface Timeline {
  seconds: number[];
  iterations: number[];
  resident: number[];
  total: number[];
  on_disk: number[];
  rss_mb: number[];
  vram_mb: number[];
  loads: number[];
  saves: number[];
  [key: string]: number[];
}

export async function fetchTimeline(): Promise<Timeline> {
  const r = await fetch("api/timeline");
  if (!r.ok) throw new Error(`api/timeline: HTTP ${r.status}`);
  return (await r.json()) as Timeline;
}

// Steps per second between consecutive samples.
function stepsPerSecond(t: Timeline): number[] {
  return t.seconds.map((s, i) =>
    i === 0 ? 0 : Math.max(0, (t.iterations[i] - t.iterations[i - 1]) / Math.max(1e-6, s - t.seconds[i - 1])),
  );
}

interface Panel {
  title: string;
  series: { label: string; stroke: string; value: (t: Timeline) => number[] }[];
}

const panels: Panel[] = [
  {
    title: "Gaussians",
    series: [
      { label: "total", stroke: "#e0e0e0", value: (t) => t.total },
      { label: "resident", stroke: "#4fc3f7", value: (t) => t.resident },
      { label: "on disk", stroke: "#ffb74d", value: (t) => t.on_disk },
    ],
  },
  {
    title: "memory (MB)",
    series: [
      { label: "host RSS", stroke: "#81c784", value: (t) => t.rss_mb },
      { label: "VRAM", stroke: "#ba68c8", value: (t) => t.vram_mb },
    ],
  },
  {
    title: "chunk I/O (cumulative)",
    series: [
      { label: "loads", stroke: "#4fc3f7", value: (t) => t.loads },
      { label: "saves", stroke: "#e57373", value: (t) => t.saves },
    ],
  },
  { title: "steps/s", series: [{ label: "steps/s", stroke: "#fff176", value: stepsPerSecond }] },
];

export class Charts {
  readonly root: HTMLDivElement;
  private plots: uPlot[] = [];

  constructor(parent: HTMLElement) {
    this.root = document.createElement("div");
    this.root.id = "charts";
    parent.appendChild(this.root);
  }

  get visible(): boolean {
    return !this.root.hidden;
  }
  set visible(v: boolean) {
    this.root.hidden = !v;
  }

  // The plots once, then their data.
  show(t: Timeline): void {
    if (!this.plots.length)
      this.plots = panels.map(
        (p) =>
          new uPlot(
            {
              title: `${p.title}: ${p.series.map((s) => s.label).join(", ")}`,
              width: 300,
              height: 110,
              legend: { show: false },
              scales: { x: { time: false } },
              axes: [
                { stroke: "#aaa", grid: { stroke: "#333" } },
                { stroke: "#aaa", grid: { stroke: "#333" }, size: 72 },
              ],
              series: [{ label: "s" }, ...p.series.map((s) => ({ label: s.label, stroke: s.stroke, width: 1.5 }))],
            },
            [[], ...p.series.map(() => [])],
            this.root,
          ),
      );
    this.plots.forEach((plot, i) => plot.setData([t.seconds, ...panels[i].series.map((s) => s.value(t))]));
  }

  samples(): number {
    return this.plots.length ? (this.plots[0].data[0]?.length ?? 0) : 0;
  }
}
