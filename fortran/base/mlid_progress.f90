!> Progress of the core's long loops (a Monte Carlo's runs, a fit's Newton
!> iterations, a text record's rows): a counter the loop sets, kept in what the call was given
!> (a handle's session, mlid-batch's own variable), never in a module
!> variable.  A front end sees it one of two ways: it reads the counter
!> from another thread while the call runs (Python, the GIL released:
!> python/mlid/progress.py's core_bar), or it gives a procedure, tell,
!> which the loop's own thread calls at most every TELL_EVERY_MS, the
!> first time after QUIET_MS, and once more when the work ends if it was
!> called before (mlid-batch's percentage line on a terminal).  Counting
!> changes no number of the work.
!>
!> A reader in another thread sees each default integer whole, before or
!> after a step (the setters' dummies are volatile: every set is a store).
module mlid_progress
  use, intrinsic :: iso_fortran_env, only: int64
  implicit none
  private
  public :: progress_t, tell_t, progress_start, progress_to, progress_stop, progress_read, &
            LABEL_LEN, QUIET_MS, TELL_EVERY_MS

  !> What runs, as a front end shows it ('monte carlo', 'reading <file>'): cut here.
  integer, parameter :: LABEL_LEN = 48
  !> Work that ends sooner shows nothing (most cases take milliseconds).
  integer, parameter :: QUIET_MS = 500
  !> A terminal line redrawn more often is not read any better.
  integer, parameter :: TELL_EVERY_MS = 100

  abstract interface
    !> What runs (label), how far (done of total; total is the end when
    !> exact, a ceiling otherwise: a fit's iteration budget), and whether
    !> the work has ended (last).
    subroutine tell_t(label, done, total, exact, last)
      character(len=*), intent(in) :: label
      integer, intent(in) :: done, total
      logical, intent(in) :: exact, last
    end subroutine tell_t
  end interface

  type :: progress_t
    character(len=LABEL_LEN) :: label = ''
    integer :: done = 0
    integer :: total = 0
    logical :: exact = .true.    !< total is the end (runs), not a ceiling (iterations)
    logical :: active = .false.  !< work is running
    integer :: phase = 0         !< one more at each start: a reader tells the work apart
    procedure(tell_t), pointer, nopass :: tell => null()
    integer(int64) :: next = 0   !< clock count from which tell is called again
    logical :: told = .false.    !< tell was called for this work
    integer :: quiet_ms = QUIET_MS  !< work shorter than this is not told
  end type progress_t

contains

  !> Work of total steps begins (nothing when p is absent).
  subroutine progress_start(p, label, total, exact)
    type(progress_t), intent(inout), volatile, optional :: p
    character(len=*), intent(in) :: label
    integer, intent(in) :: total
    logical, intent(in) :: exact
    integer(int64) :: now, rate
    if (.not. present(p)) return
    p%label = label
    p%total = total
    p%exact = exact
    p%done = 0
    p%told = .false.
    p%phase = p%phase + 1
    p%active = .true.
    if (.not. associated(p%tell)) return
    call system_clock(now, rate)
    p%next = now + int(p%quiet_ms, int64)*rate/1000
  end subroutine progress_start

  !> done steps of the work are done.
  subroutine progress_to(p, done)
    type(progress_t), intent(inout), volatile, optional :: p
    integer, intent(in) :: done
    integer(int64) :: now, rate
    if (.not. present(p)) return
    p%done = done
    if (.not. associated(p%tell)) return
    call system_clock(now, rate)
    if (now < p%next) return
    call p%tell(p%label, p%done, p%total, p%exact, .false.)
    p%told = .true.
    p%next = now + TELL_EVERY_MS*rate/1000
  end subroutine progress_to

  !> The work has ended, finished or not.
  subroutine progress_stop(p)
    type(progress_t), intent(inout), volatile, optional :: p
    if (.not. present(p)) return
    p%active = .false.
    if (associated(p%tell) .and. p%told) call p%tell(p%label, p%done, p%total, p%exact, .true.)
    p%told = .false.
  end subroutine progress_stop

  !> What p says now, as integers (exact, active: 1 or 0), for a reader
  !> in another thread (each call reads memory afresh).  No lock: at the
  !> instant one piece of work starts a reader may see some fields of the
  !> last one; what it draws is a bar, redrawn a tenth of a second later.
  subroutine progress_read(p, label, done, total, exact, active, phase)
    type(progress_t), intent(in) :: p
    character(len=*), intent(out) :: label
    integer, intent(out) :: done, total, exact, active, phase
    label = p%label
    done = p%done
    total = p%total
    exact = merge(1, 0, p%exact)
    active = merge(1, 0, p%active)
    phase = p%phase
  end subroutine progress_read

end module mlid_progress
