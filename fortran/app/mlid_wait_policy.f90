!> A brief spin for mlid-batch's waiting OpenMP threads, as mlid's Python
!> package asks for it (python/mlid/openmp.py, which says why: libgomp's
!> default spins a waiting thread for milliseconds, passive waiting pays a
!> wake-up at every region).  libgomp reads GOMP_SPINCOUNT once, when it is
!> loaded, before this program starts; so when the environment does not
!> choose (WAIT_VARIABLES: openmp.py's WAIT_VARIABLES), the program sets it
!> and starts itself again, once, with the same arguments.  Not
!> when threads are bound (BINDING_VARIABLES): libgomp has bound this
!> process to one CPU already, and the binding would outlast the start
!> (one CPU for all the threads); not under valgrind, whose tool would not
!> follow; not when the dynamic loader was run with this program as its
!> argument (/proc/self/exe names the loader then).  If it cannot start
!> again it goes on as it is: only the CPU time differs, never the values
!> computed.
module mlid_wait_policy
  use, intrinsic :: iso_c_binding, only: c_char, c_int, c_long, c_ptrdiff_t, c_size_t, c_ptr, &
                                         c_loc, c_null_ptr, c_null_char
  implicit none
  private
  public :: brief_spin

  !> The variables by which the environment chooses how threads wait
  !> (openmp.py's WAIT_VARIABLES; the _ALL form is newer libgomp's).
  character(len=*), parameter :: WAIT_VARIABLES(3) = ['OMP_WAIT_POLICY    ', &
                                                      'OMP_WAIT_POLICY_ALL', &
                                                      'GOMP_SPINCOUNT     ']
  !> The variables with which libgomp binds threads (the first on loading;
  !> openmp.py's BINDING_VARIABLES).
  character(len=*), parameter :: BINDING_VARIABLES(4) = ['OMP_PROC_BIND     ', &
                                                         'OMP_PROC_BIND_ALL ', &
                                                         'OMP_PLACES        ', &
                                                         'GOMP_CPU_AFFINITY ']
  !> Rounds a waiting thread spins before it sleeps (openmp.py's SPIN_COUNT).
  character(len=*), parameter :: SPIN_COUNT = '10000'
  !> The link to this program's file, whose target is run rather than the
  !> link itself: under valgrind the link names valgrind's tool.
  character(len=*), parameter :: SELF = '/proc/self/exe'
  !> getauxval's key for the dynamic loader's address: 0 when the loader
  !> was run as a program, with this one as its argument.
  integer(c_long), parameter :: AT_BASE = 7

  interface
    integer(c_int) function setenv(name, value, overwrite) bind(C, name='setenv')
      import :: c_char, c_int
      character(kind=c_char), intent(in) :: name(*), value(*)
      integer(c_int), value, intent(in) :: overwrite
    end function setenv
    integer(c_ptrdiff_t) function readlink(path, buf, size) bind(C, name='readlink')  ! ssize_t
      import :: c_char, c_ptrdiff_t, c_size_t
      character(kind=c_char), intent(in) :: path(*)
      character(kind=c_char), intent(out) :: buf(*)
      integer(c_size_t), value, intent(in) :: size
    end function readlink
    integer(c_long) function getauxval(key) bind(C, name='getauxval')   ! unsigned long
      import :: c_long
      integer(c_long), value, intent(in) :: key
    end function getauxval
    integer(c_int) function execv(path, argv) bind(C, name='execv')
      import :: c_char, c_int, c_ptr
      character(kind=c_char), intent(in) :: path(*)
      type(c_ptr), intent(in) :: argv(*)
    end function execv
  end interface

contains

  !> Set GOMP_SPINCOUNT=SPIN_COUNT and start again, unless the environment
  !> chooses, binds threads, runs valgrind or was loaded by the loader run
  !> as a program; returns only when it does not start again.
  subroutine brief_spin()
    character(kind=c_char, len=4096) :: path
    character(len=4096) :: preload
    integer(c_ptrdiff_t) :: n

    if (any(is_set(WAIT_VARIABLES)) .or. any(is_set(BINDING_VARIABLES))) return
    call get_environment_variable('LD_PRELOAD', preload)
    if (index(preload, 'vgpreload') > 0) return          ! valgrind's own libraries
    if (getauxval(AT_BASE) == 0) return
    n = readlink(SELF//c_null_char, path, int(len(path) - 1, c_size_t))
    if (n <= 0 .or. n >= len(path) - 1) return
    if (setenv('GOMP_SPINCOUNT'//c_null_char, SPIN_COUNT//c_null_char, 1_c_int) /= 0) return
    call start_again(path(1:n)//c_null_char)
  end subroutine brief_spin

  !> Whether each variable is set (even empty).
  impure elemental logical function is_set(name)
    character(len=*), intent(in) :: name
    integer :: status
    call get_environment_variable(trim(name), status=status)
    is_set = status == 0
  end function is_set

  !> execv the program at path (null-terminated) with this one's arguments;
  !> returns only when that fails.
  subroutine start_again(path)
    character(kind=c_char, len=*), intent(in) :: path
    type :: c_string_t
      character(kind=c_char, len=:), allocatable :: s
    end type c_string_t
    type(c_string_t), allocatable, target :: args(:)
    type(c_ptr), allocatable :: argv(:)
    integer :: k, n, length

    n = command_argument_count()
    allocate (args(0:n), argv(0:n + 1))
    do k = 0, n
      call get_command_argument(k, length=length)
      allocate (character(kind=c_char, len=length + 1) :: args(k)%s)
      call get_command_argument(k, args(k)%s(1:length))
      args(k)%s(length + 1:) = c_null_char
      argv(k) = c_loc(args(k)%s)
    end do
    argv(n + 1) = c_null_ptr
    k = execv(path, argv)
  end subroutine start_again

end module mlid_wait_policy
